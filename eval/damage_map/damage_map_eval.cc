#include "eval/damage_map/damage_map_eval.h"

#include <GeographicLib/LocalCartesian.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <Eigen/Core>
#include <opencv2/core/eigen.hpp>

#include <algorithm>
#include <sstream>
#include <cmath>
#include <set>
#include <stdexcept>
#include <variant>

#include "eval/damage/sim_truth.h"
#include "eval/georeference/georeference_eval.h"
#include "formats/damage/detections_file.h"
#include "formats/trajectory/tum_trajectory.h"
#include "formats/input_error.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

using nlohmann::json;

// ---------------------------------------------------------------- features on the road plane

// A feature in the truth's local ENU, horizontal (x east, y north), metres.
struct PlaneFeature {
  int id = 0;
  std::string type;
  std::vector<std::vector<cv::Point2d>> rings;  // polygons: every ring of every polygon (even-odd)
  std::vector<char> hole;                       // per ring: a hole (not a polygon's exterior)
  std::vector<cv::Point2d> line;                // LineString
  cv::Rect2d box;                               // bounding box of the geometry
  double area_m2 = 0;                           // polygons: exterior areas − hole areas
  double length_m = 0;                          // lines
  cv::Point2d centroid;                         // polygons: area centroid; lines: the point halfway along
  const json* properties = nullptr;
  bool IsPolygon() const { return !rings.empty(); }
  bool IsLine() const { return !line.empty(); }
};

double Cross(const cv::Point2d& a, const cv::Point2d& b) { return a.x * b.y - a.y * b.x; }

// Distance from p to the segment ab.
double SegmentDistance(const cv::Point2d& p, const cv::Point2d& a, const cv::Point2d& b) {
  const cv::Point2d ab = b - a;
  const double len2 = ab.dot(ab);
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  const cv::Point2d q = a + t * ab;
  return std::hypot(p.x - q.x, p.y - q.y);
}

double PolylineDistance(const cv::Point2d& p, const std::vector<cv::Point2d>& line) {
  double d = std::numeric_limits<double>::infinity();
  if (line.size() == 1) return std::hypot(p.x - line[0].x, p.y - line[0].y);
  for (size_t i = 0; i + 1 < line.size(); ++i) d = std::min(d, SegmentDistance(p, line[i], line[i + 1]));
  return d;
}

// Even-odd rule over every ring (holes and several polygons alike).
bool InsidePolygon(const cv::Point2d& p, const PlaneFeature& f) {
  bool inside = false;
  for (const auto& ring : f.rings) {
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
      const cv::Point2d &a = ring[i], &b = ring[j];
      if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) inside = !inside;
    }
  }
  return inside;
}

// Distance from p to a feature's geometry: 0 inside a polygon.
double FeatureDistance(const cv::Point2d& p, const PlaneFeature& f) {
  if (f.IsLine()) return PolylineDistance(p, f.line);
  if (InsidePolygon(p, f)) return 0;
  double d = std::numeric_limits<double>::infinity();
  for (const auto& ring : f.rings) {
    std::vector<cv::Point2d> closed = ring;
    closed.push_back(ring.front());
    d = std::min(d, PolylineDistance(p, closed));
  }
  return d;
}

double PolylineLength(const std::vector<cv::Point2d>& line) {
  double len = 0;
  for (size_t i = 0; i + 1 < line.size(); ++i) len += std::hypot(line[i + 1].x - line[i].x, line[i + 1].y - line[i].y);
  return len;
}

// The point at distance s along the line.
cv::Point2d PointAlong(const std::vector<cv::Point2d>& line, double s) {
  for (size_t i = 0; i + 1 < line.size(); ++i) {
    const double seg = std::hypot(line[i + 1].x - line[i].x, line[i + 1].y - line[i].y);
    if (s <= seg && seg > 0) return line[i] + (s / seg) * (line[i + 1] - line[i]);
    s -= seg;
  }
  return line.back();
}

// Points every `step` along the line, both ends included.
std::vector<cv::Point2d> SampleLine(const std::vector<cv::Point2d>& line, double step) {
  std::vector<cv::Point2d> out;
  out.push_back(line.front());
  for (size_t i = 0; i + 1 < line.size(); ++i) {
    const cv::Point2d d = line[i + 1] - line[i];
    const double seg = std::hypot(d.x, d.y);
    const int n = static_cast<int>(std::ceil(seg / step));
    for (int k = 1; k <= n; ++k) out.push_back(line[i] + (static_cast<double>(k) / n) * d);
  }
  return out;
}

cv::Rect2d BoundingBox(const std::vector<cv::Point2d>& pts, cv::Rect2d box, bool first) {
  for (const auto& p : pts) {
    if (first) {
      box = cv::Rect2d(p.x, p.y, 0, 0);
      first = false;
      continue;
    }
    const double x0 = std::min(box.x, p.x), y0 = std::min(box.y, p.y);
    const double x1 = std::max(box.x + box.width, p.x), y1 = std::max(box.y + box.height, p.y);
    box = cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
  }
  return box;
}

bool BoxesMeet(const cv::Rect2d& a, const cv::Rect2d& b, double margin) {
  return a.x - margin <= b.x + b.width && b.x - margin <= a.x + a.width && a.y - margin <= b.y + b.height &&
         b.y - margin <= a.y + a.height;
}

class Converter {
 public:
  explicit Converter(const EnuOrigin& o) : h0_(o.h_ellipsoid_m), enu_(o.lat_deg, o.lon_deg, o.h_ellipsoid_m) {}
  cv::Point2d ToEnu(const geojson::Position& q) const {
    double x, y, z;
    enu_.Forward(q.lat_deg, q.lon_deg, q.h_m.value_or(h0_), x, y, z);
    return {x, y};
  }
  void ToLatLon(const cv::Point2d& p, double* lat, double* lon) const {
    double h;
    enu_.Reverse(p.x, p.y, 0, *lat, *lon, h);
  }

 private:
  double h0_;
  GeographicLib::LocalCartesian enu_;
};

// Signed shoelace area and centroid of a ring (closing point optional).
void RingMoments(const std::vector<cv::Point2d>& r, double* area, cv::Point2d* centroid) {
  double a = 0, cx = 0, cy = 0;
  for (size_t i = 0; i < r.size(); ++i) {
    const cv::Point2d& p = r[i];
    const cv::Point2d& q = r[(i + 1) % r.size()];
    const double c = Cross(p, q);
    a += c;
    cx += (p.x + q.x) * c;
    cy += (p.y + q.y) * c;
  }
  *area = 0.5 * a;
  *centroid = std::abs(a) > 0 ? cv::Point2d(cx / (3 * a), cy / (3 * a)) : (r.empty() ? cv::Point2d() : r.front());
}

std::vector<cv::Point2d> RingToEnu(const geojson::Ring& ring, const Converter& c) {
  std::vector<cv::Point2d> out;
  for (const auto& q : ring) out.push_back(c.ToEnu(q));
  if (out.size() > 1 && out.front() == out.back()) out.pop_back();
  return out;
}

InputError FeatureError(const std::string& path, size_t index, const std::string& message) {
  return InputError(InputLocation::File(path), fmt::format("feature #{}: {}", index, message));
}

// `truth`: truth/damages.geojson's rules (potholes need polygons, cracks lines); else the map's
// ("pothole", "crack", "other").
std::vector<PlaneFeature> ToPlane(const geojson::FeatureCollection& fc, const Converter& conv, bool truth,
                                  const std::string& path) {
  std::vector<PlaneFeature> out;
  std::set<int> ids;
  for (size_t i = 0; i < fc.features.size(); ++i) {
    const geojson::Feature& g = fc.features[i];
    const json& p = g.properties;
    if (!p.is_object() || !p.contains("id") || !p["id"].is_number_integer() || !p.contains("type") ||
        !p["type"].is_string())
      throw FeatureError(path, i, "needs properties with an integer id and a string type");
    PlaneFeature f;
    f.id = p["id"].get<int>();
    f.type = p["type"].get<std::string>();
    f.properties = &p;
    if (!ids.insert(f.id).second) throw FeatureError(path, i, fmt::format("id {} appears twice", f.id));
    const std::string where = fmt::format("id {} ({})", f.id, f.type);
    if (!truth && f.type != "pothole" && f.type != "crack" && f.type != "other")
      throw FeatureError(path, i, where + ": type must be pothole, crack or other");
    if (const auto* poly = std::get_if<geojson::Polygon>(&g.geometry)) {
      for (size_t r = 0; r < poly->rings.size(); ++r) {
        f.rings.push_back(RingToEnu(poly->rings[r], conv));
        f.hole.push_back(r > 0);
      }
    } else if (const auto* multi = std::get_if<geojson::MultiPolygon>(&g.geometry)) {
      for (const auto& pg : multi->polygons)
        for (size_t r = 0; r < pg.rings.size(); ++r) {
          f.rings.push_back(RingToEnu(pg.rings[r], conv));
          f.hole.push_back(r > 0);
        }
    } else if (const auto* line = std::get_if<geojson::LineString>(&g.geometry)) {
      for (const auto& q : line->positions) f.line.push_back(conv.ToEnu(q));
    }
    for (const auto& r : f.rings)
      if (r.size() < 3) throw FeatureError(path, i, where + ": a polygon ring with fewer than 3 positions");
    if (f.IsLine() && f.line.size() < 2)
      throw FeatureError(path, i, where + ": a LineString with fewer than 2 positions");
    const bool pothole = f.type == "pothole";
    const bool crack = truth ? f.type.rfind("crack_", 0) == 0 : f.type == "crack";
    if (pothole && !f.IsPolygon()) throw FeatureError(path, i, where + ": a pothole must be a Polygon or MultiPolygon");
    if (crack && !f.IsLine()) throw FeatureError(path, i, where + ": a crack must be a LineString");
    if (f.IsPolygon()) {
      double sx = 0, sy = 0;
      bool first = true;
      for (size_t r = 0; r < f.rings.size(); ++r) {
        double a;
        cv::Point2d c;
        RingMoments(f.rings[r], &a, &c);
        const double w = f.hole[r] ? -std::abs(a) : std::abs(a);
        f.area_m2 += w;
        sx += w * c.x;
        sy += w * c.y;
        f.box = BoundingBox(f.rings[r], f.box, first);
        first = false;
      }
      f.centroid = f.area_m2 > 0 ? cv::Point2d(sx / f.area_m2, sy / f.area_m2) : f.rings[0][0];
    } else if (f.IsLine()) {
      f.length_m = PolylineLength(f.line);
      f.centroid = PointAlong(f.line, 0.5 * f.length_m);
      f.box = BoundingBox(f.line, f.box, true);
    } else if (const auto* pt = std::get_if<geojson::Point>(&g.geometry)) {
      f.centroid = conv.ToEnu(pt->position);
      f.box = cv::Rect2d(f.centroid.x, f.centroid.y, 0, 0);
    }
    out.push_back(std::move(f));
  }
  return out;
}

// A number property: NaN when absent or null; an error when of another type or not finite.
double Number(const PlaneFeature& f, const char* key, const std::string& path) {
  const json& p = *f.properties;
  if (!p.contains(key) || p[key].is_null()) return kNoValue;
  if (!p[key].is_number() || !std::isfinite(p[key].get<double>()))
    throw InputError(InputLocation::File(path),
                     fmt::format("id {} ({}): {} must be a finite number or null", f.id, f.type, key));
  return p[key].get<double>();
}

double RequiredNumber(const PlaneFeature& f, const char* key, const std::string& path) {
  const double v = Number(f, key, path);
  if (std::isnan(v))
    throw InputError(InputLocation::File(path), fmt::format("id {} ({}): {} is missing", f.id, f.type, key));
  return v;
}

std::optional<bool> Flag(const PlaneFeature& f, const char* key, const std::string& path) {
  const json& p = *f.properties;
  if (!p.contains(key) || p[key].is_null()) return std::nullopt;
  if (!p[key].is_boolean())
    throw InputError(InputLocation::File(path),
                     fmt::format("id {} ({}): {} must be true, false or null", f.id, f.type, key));
  return p[key].get<bool>();
}

// ---------------------------------------------------------------- overlap of polygons

// Cells of a grid (origin = lower-left corner, `cols` × `rows` cells of `cell` m) whose centres lie
// inside the feature (even-odd rule over all rings): unbiased, unlike filling with edge pixels.
cv::Mat Rasterize(const PlaneFeature& f, const cv::Point2d& origin, double cell, int cols, int rows) {
  cv::Mat m(rows, cols, CV_8U, cv::Scalar(0));
  std::vector<double> xs;
  for (int r = 0; r < rows; ++r) {
    const double yc = origin.y + (r + 0.5) * cell;
    xs.clear();
    for (const auto& ring : f.rings)
      for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
        const cv::Point2d &a = ring[i], &b = ring[j];
        if ((a.y > yc) != (b.y > yc)) xs.push_back(a.x + (yc - a.y) * (b.x - a.x) / (b.y - a.y));
      }
    std::sort(xs.begin(), xs.end());
    uchar* row = m.ptr<uchar>(r);
    for (size_t k = 0; k + 1 < xs.size(); k += 2) {
      // Cells whose centre x0 + (c + 0.5)·cell lies in [xs[k], xs[k+1]).
      const int c0 = std::max(0, static_cast<int>(std::ceil((xs[k] - origin.x) / cell - 0.5)));
      const int c1 = std::min(cols - 1, static_cast<int>(std::ceil((xs[k + 1] - origin.x) / cell - 0.5)) - 1);
      for (int c = c0; c <= c1; ++c) row[c] = 1;
    }
  }
  return m;
}

struct Overlap {
  double intersection_m2 = 0, area_a_m2 = 0, area_b_m2 = 0;
  double Ratio() const {
    const double m = std::min(area_a_m2, area_b_m2);
    return m > 0 ? intersection_m2 / m : 0;
  }
  double Iou() const {
    const double u = area_a_m2 + area_b_m2 - intersection_m2;
    return u > 0 ? intersection_m2 / u : 0;
  }
};

// Both polygons rasterised on one grid over their common bounding box.
Overlap PolygonOverlap(const PlaneFeature& a, const PlaneFeature& b, double cell) {
  Overlap o;
  if (!BoxesMeet(a.box, b.box, 0)) return o;
  const double x0 = std::min(a.box.x, b.box.x), y0 = std::min(a.box.y, b.box.y);
  const double x1 = std::max(a.box.x + a.box.width, b.box.x + b.box.width);
  const double y1 = std::max(a.box.y + a.box.height, b.box.y + b.box.height);
  // A runaway outline (hundreds of metres) would ask for a huge grid: coarsen to at most 4096².
  cell = std::max({cell, (x1 - x0) / 4096, (y1 - y0) / 4096});
  const int cols = static_cast<int>(std::ceil((x1 - x0) / cell)) + 1;
  const int rows = static_cast<int>(std::ceil((y1 - y0) / cell)) + 1;
  const cv::Mat ma = Rasterize(a, {x0, y0}, cell, cols, rows);
  const cv::Mat mb = Rasterize(b, {x0, y0}, cell, cols, rows);
  const double c2 = cell * cell;
  o.area_a_m2 = cv::countNonZero(ma) * c2;
  o.area_b_m2 = cv::countNonZero(mb) * c2;
  o.intersection_m2 = cv::countNonZero(ma & mb) * c2;
  return o;
}

// Share of `samples` within `tolerance` of the feature (a line, or a polygon: inside counts).
double Coverage(const std::vector<cv::Point2d>& samples, const PlaneFeature& f, double tolerance) {
  if (samples.empty()) return 0;
  int near = 0;
  for (const auto& s : samples) near += FeatureDistance(s, f) <= tolerance ? 1 : 0;
  return static_cast<double>(near) / samples.size();
}

// ---------------------------------------------------------------- one-to-one assignment

struct Candidate {
  int p = 0, t = 0;  // indices into the predictions and the truths
  double score = 0;  // overlap ratio or coverage (already past the threshold)
  double key = 0;    // what is assigned first: intersection area or covered length
};

struct Assignment {
  std::vector<int> truth_of;      // per prediction: the truth it matched, -1
  std::vector<int> duplicate_of;  // per unmatched prediction: the matched truth it also matches, -1
  std::vector<int> pred_of;       // per truth: the prediction that matched it, -1
  std::vector<double> score_of;   // per prediction: the score with truth_of / duplicate_of
};

// Greedy by descending key: the largest overlap is assigned first.
Assignment Assign(std::vector<Candidate> c, size_t predictions, size_t truths) {
  std::sort(c.begin(), c.end(), [](const Candidate& a, const Candidate& b) {
    if (a.key != b.key) return a.key > b.key;
    if (a.score != b.score) return a.score > b.score;
    return a.p != b.p ? a.p < b.p : a.t < b.t;
  });
  Assignment a;
  a.truth_of.assign(predictions, -1);
  a.duplicate_of.assign(predictions, -1);
  a.score_of.assign(predictions, 0);
  a.pred_of.assign(truths, -1);
  for (const Candidate& k : c)
    if (a.truth_of[k.p] < 0 && a.pred_of[k.t] < 0) {
      a.truth_of[k.p] = k.t;
      a.pred_of[k.t] = k.p;
      a.score_of[k.p] = k.score;
    }
  for (const Candidate& k : c)
    if (a.truth_of[k.p] < 0 && a.duplicate_of[k.p] < 0 && a.pred_of[k.t] >= 0) {
      a.duplicate_of[k.p] = k.t;
      a.score_of[k.p] = k.score;
    }
  return a;
}

// ---------------------------------------------------------------- figures

double Median(std::vector<double> v) {
  if (v.empty()) return kNoValue;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// `values` with NaN skipped; verdicts beside them (empty = not judged).
ErrorSummary Summarise(const std::vector<double>& values, const std::vector<std::optional<bool>>& verdicts,
                       double tolerance) {
  ErrorSummary s;
  s.tolerance = tolerance;
  std::vector<double> abs;
  for (double v : values)
    if (std::isfinite(v)) {
      abs.push_back(std::abs(v));
      if (std::isfinite(tolerance) && std::abs(v) <= tolerance) ++s.within_tolerance;
    }
  s.n = static_cast<int>(abs.size());
  if (!abs.empty()) {
    s.median_abs = Median(abs);
    s.max_abs = *std::max_element(abs.begin(), abs.end());
    s.min_abs = *std::min_element(abs.begin(), abs.end());
  }
  for (const auto& v : verdicts)
    if (v) {
      ++s.judged;
      s.within_uncertainty += *v ? 1 : 0;
    }
  return s;
}

double Ratio(int num, int den) { return den > 0 ? static_cast<double>(num) / den : kNoValue; }

double PercentError(double predicted, double truth) {
  return std::isfinite(predicted) && std::isfinite(truth) && truth > 0 ? 100 * (predicted - truth) / truth : kNoValue;
}

// |predicted − truth| <= k·σ; empty without the numbers.
std::optional<bool> WithinSigma(double predicted, double truth, double sigma, double k) {
  if (!std::isfinite(predicted) || !std::isfinite(truth) || !std::isfinite(sigma)) return std::nullopt;
  return std::abs(predicted - truth) <= k * sigma;
}

FalseDamage MakeFalse(const PlaneFeature& f, const std::vector<PlaneFeature>& truth, const Converter& conv,
                      const std::string& path) {
  FalseDamage d;
  d.predicted_id = f.id;
  d.centroid_enu_m = f.centroid;
  conv.ToLatLon(f.centroid, &d.lat_deg, &d.lon_deg);
  d.chainage_m = Number(f, "chainage_m", path);
  d.offset_m = Number(f, "offset_m", path);
  for (const PlaneFeature& t : truth) {
    const double dist = FeatureDistance(f.centroid, t);
    if (!(dist >= d.nearest_truth_distance_m)) {  // NaN at first
      d.nearest_truth_distance_m = dist;
      d.nearest_truth_id = t.id;
      d.nearest_truth_type = t.type;
    }
  }
  return d;
}

TruthSight SightOf(const TruthSightings& s, int id) {
  const auto it = s.find(id);
  return it == s.end() ? TruthSight::kUnseen : it->second.Sight();
}

int FramesWhole(const TruthSightings& s, int id) {
  const auto it = s.find(id);
  return it == s.end() ? 0 : it->second.frames_whole;
}

// Counts the truth of one scored type and says which truths are in the assignment and scored.
void CountTruth(const std::vector<const PlaneFeature*>& truths, const TruthSightings& sightings,
                const std::vector<bool>& big_enough, DamageTypeCounts* counts, std::vector<bool>* assignable,
                std::vector<bool>* scored) {
  counts->truth = static_cast<int>(truths.size());
  for (size_t j = 0; j < truths.size(); ++j) {
    const TruthSight s = SightOf(sightings, truths[j]->id);
    (*assignable)[j] = s != TruthSight::kUnseen;
    (*scored)[j] = s == TruthSight::kWhole && big_enough[j];
    if (s == TruthSight::kUnseen)
      ++counts->unseen;
    else if (s == TruthSight::kPartial)
      ++counts->partial;
    else if (!big_enough[j])
      ++counts->small;
    else
      ++counts->seen;
  }
}

void Finish(DamageTypeCounts* c) {
  c->recall = Ratio(c->matched, c->seen);
  c->precision = Ratio(c->matched, c->matched + c->duplicates + c->false_positives);
}

// ---------------------------------------------------------------- output helpers

json Num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json Opt(const std::optional<bool>& v) { return v ? json(*v) : json(nullptr); }

std::string Fix(double v, int decimals, int width) {
  return std::isfinite(v) ? fmt::format("{:>{}.{}f}", v, width, decimals) : fmt::format("{:>{}}", "-", width);
}
std::string Verdict(const std::optional<bool>& v) { return v ? (*v ? "yes" : "NO") : "-"; }
std::string Share(int num, int den) {
  return den > 0 ? fmt::format("{}/{} ({:.0f} %)", num, den, 100.0 * num / den) : std::string("-");
}

json SummaryJson(const ErrorSummary& s) {
  json j = {{"n", s.n}, {"median_abs", Num(s.median_abs)}, {"max_abs", Num(s.max_abs)}, {"min_abs", Num(s.min_abs)}};
  if (std::isfinite(s.tolerance)) {
    j["tolerance"] = s.tolerance;
    j["within_tolerance"] = s.within_tolerance;
    j["within_tolerance_fraction"] = Num(Ratio(s.within_tolerance, s.n));
  }
  j["judged_by_uncertainty"] = s.judged;
  j["within_uncertainty"] = s.within_uncertainty;
  j["within_uncertainty_fraction"] = Num(Ratio(s.within_uncertainty, s.judged));
  return j;
}

json CountsJson(const DamageTypeCounts& c) {
  return {{"truth", c.truth},
          {"seen", c.seen},
          {"partial", c.partial},
          {"unseen", c.unseen},
          {"small", c.small},
          {"predicted", c.predicted},
          {"matched", c.matched},
          {"matched_unscored", c.unscored},
          {"duplicates", c.duplicates},
          {"false_positives", c.false_positives},
          {"misses", c.misses},
          {"recall", Num(c.recall)},
          {"precision", Num(c.precision)}};
}

json MissesJson(const std::vector<MissedDamage>& v) {
  json a = json::array();
  for (const auto& m : v) {
    json j = {{"truth_id", m.truth_id}, {"frames_whole", m.frames_whole}};
    j["typed_otherwise"] =
        m.typed_otherwise_id ? json{{"id", m.typed_otherwise_id}, {"type", m.typed_otherwise_as}} : json(nullptr);
    a.push_back(j);
  }
  return a;
}

json DuplicatesJson(const std::vector<DuplicateDamage>& v, const char* score) {
  json a = json::array();
  for (const auto& d : v) a.push_back({{"predicted_id", d.predicted_id}, {"truth_id", d.truth_id}, {score, d.overlap}});
  return a;
}

json FalseJson(const std::vector<FalseDamage>& v) {
  json a = json::array();
  for (const auto& f : v)
    a.push_back({{"predicted_id", f.predicted_id},
                 {"centroid_enu_m", {f.centroid_enu_m.x, f.centroid_enu_m.y}},
                 {"lat_deg", f.lat_deg},
                 {"lon_deg", f.lon_deg},
                 {"chainage_m", Num(f.chainage_m)},
                 {"offset_m", Num(f.offset_m)},
                 {"nearest_truth", f.nearest_truth_id ? json{{"id", f.nearest_truth_id},
                                                             {"type", f.nearest_truth_type},
                                                             {"distance_m", f.nearest_truth_distance_m}}
                                                      : json(nullptr)}});
  return a;
}

std::string CountsRow(const std::string& name, const DamageTypeCounts& c) {
  return fmt::format("{:<9} {:>5} {:>5} {:>7} {:>5} {:>6} {:>5} {:>7} {:>8} {:>4} {:>3} {:>5} {} {}\n", name, c.truth,
                     c.seen, c.partial, c.small, c.unseen, c.predicted, c.matched, c.unscored, c.duplicates,
                     c.false_positives, c.misses, Fix(c.recall, 3, 6), Fix(c.precision, 3, 9));
}

std::string SummaryRow(const std::string& name, const ErrorSummary& s, int decimals, const std::string& unit) {
  std::string tol = "-";
  if (std::isfinite(s.tolerance))
    tol = fmt::format("{} within {:g} {}", Share(s.within_tolerance, s.n), s.tolerance, unit);
  return fmt::format("  {:<16} n {:>3}  median {}  max {}  {:<28} stated: {}\n", name, s.n,
                     Fix(s.median_abs, decimals, 7), Fix(s.max_abs, decimals, 7), tol,
                     Share(s.within_uncertainty, s.judged));
}

std::string FalseLines(const std::vector<FalseDamage>& v) {
  std::string s;
  for (const auto& f : v) {
    s += fmt::format("    {:>4} at E {:.2f} N {:.2f} (lat {:.8f} lon {:.8f}; chainage {} m offset {} m)",
                     f.predicted_id, f.centroid_enu_m.x, f.centroid_enu_m.y, f.lat_deg, f.lon_deg,
                     Fix(f.chainage_m, 2, 1), Fix(f.offset_m, 2, 1));
    if (f.nearest_truth_id)
      s += fmt::format("; nearest truth {} {} at {:.2f} m", f.nearest_truth_id, f.nearest_truth_type,
                       f.nearest_truth_distance_m);
    s += "\n";
  }
  return s;
}

std::string MissLines(const std::vector<MissedDamage>& v) {
  std::string s;
  for (const auto& m : v) {
    s += fmt::format("    truth {:>4} (whole in {} frames)", m.truth_id, m.frames_whole);
    if (m.typed_otherwise_id) s += fmt::format("; mapped as {} {}", m.typed_otherwise_as, m.typed_otherwise_id);
    s += "\n";
  }
  return s;
}

}  // namespace

// ---------------------------------------------------------------- options

void DamageMapEvalOptions::Check() const {
  auto rule = [](bool ok, const char* name, double value, const char* text) {
    if (!ok) throw std::invalid_argument(fmt::format("{} = {:g} violates {}", name, value, text));
  };
  rule(min_pothole_diameter_m >= 0, "min_pothole_diameter_m", min_pothole_diameter_m, "min_pothole_diameter_m >= 0");
  rule(min_crack_length_m >= 0, "min_crack_length_m", min_crack_length_m, "min_crack_length_m >= 0");
  rule(min_overlap > 0 && min_overlap <= 1, "min_overlap", min_overlap, "0 < min_overlap <= 1");
  rule(cell_m > 0 && cell_m <= 0.1, "cell_m", cell_m, "0 < cell_m <= 0.1");
  rule(crack_tolerance_m > 0, "crack_tolerance_m", crack_tolerance_m, "crack_tolerance_m > 0");
  rule(min_crack_coverage > 0 && min_crack_coverage <= 1, "min_crack_coverage", min_crack_coverage,
       "0 < min_crack_coverage <= 1");
  rule(min_line_seen > 0 && min_line_seen <= 1, "min_line_seen", min_line_seen, "0 < min_line_seen <= 1");
  rule(crack_sample_m > 0 && crack_sample_m <= crack_tolerance_m, "crack_sample_m", crack_sample_m,
       "0 < crack_sample_m <= crack_tolerance_m");
  rule(min_seen_pixels >= 1, "min_seen_pixels", min_seen_pixels, "min_seen_pixels >= 1");
  rule(border_px >= 0, "border_px", border_px, "border_px >= 0");
  rule(depth_tolerance_m > 0, "depth_tolerance_m", depth_tolerance_m, "depth_tolerance_m > 0");
  rule(area_tolerance_pct > 0, "area_tolerance_pct", area_tolerance_pct, "area_tolerance_pct > 0");
  rule(volume_tolerance_pct > 0, "volume_tolerance_pct", volume_tolerance_pct, "volume_tolerance_pct > 0");
  rule(sigma_factor > 0, "sigma_factor", sigma_factor, "sigma_factor > 0");
}

json DamageMapEvalOptions::ToJson() const {
  return {{"min_pothole_diameter_m", min_pothole_diameter_m},
          {"min_crack_length_m", min_crack_length_m},
          {"min_overlap", min_overlap},
          {"cell_m", cell_m},
          {"crack_tolerance_m", crack_tolerance_m},
          {"min_crack_coverage", min_crack_coverage},
          {"crack_sample_m", crack_sample_m},
          {"min_line_seen", min_line_seen},
          {"remove_placement_offset", remove_placement_offset},
          {"min_seen_pixels", min_seen_pixels},
          {"border_px", border_px},
          {"depth_tolerance_m", depth_tolerance_m},
          {"area_tolerance_pct", area_tolerance_pct},
          {"volume_tolerance_pct", volume_tolerance_pct},
          {"sigma_factor", sigma_factor}};
}

const char* TruthSightName(TruthSight s) {
  switch (s) {
    case TruthSight::kUnseen: return "unseen";
    case TruthSight::kPartial: return "partial";
    case TruthSight::kWhole: return "whole";
  }
  return "?";
}

// ---------------------------------------------------------------- sightings

void AddFrameSightings(const cv::Mat& masks, const DamageMapEvalOptions& o, TruthSightings* sightings,
                       const cv::Mat& disparity, double bf, double max_range_m) {
  if (masks.type() != CV_16UC1) throw std::invalid_argument("AddFrameSightings: the truth mask must be CV_16UC1");
  const bool ranged = std::isfinite(max_range_m) && !disparity.empty();
  if (ranged && (disparity.type() != CV_32FC1 || disparity.size() != masks.size()))
    throw std::invalid_argument("AddFrameSightings: the truth disparity must be CV_32FC1 of the mask's size");
  const float min_disparity = ranged ? static_cast<float>(bf / max_range_m) : 0.0f;
  std::vector<int> count(65536, 0);
  std::vector<char> border(65536, 0);
  const int b = o.border_px;
  for (int v = 0; v < masks.rows; ++v) {
    const uint16_t* row = masks.ptr<uint16_t>(v);
    const bool edge_row = v < b || v >= masks.rows - b;
    for (int u = 0; u < masks.cols; ++u) {
      const uint16_t id = row[u];
      if (id == 0) continue;
      ++count[id];
      if (edge_row || u < b || u >= masks.cols - b) border[id] = 1;
      if (ranged && !(disparity.at<float>(v, u) >= min_disparity)) border[id] = 1;  // beyond the analysed range
    }
  }
  for (int id = 1; id < 65536; ++id) {
    if (count[id] == 0) continue;
    TruthSighting& s = (*sightings)[id];
    if (count[id] >= o.min_seen_pixels && !border[id])
      ++s.frames_whole;
    else
      ++s.frames_partial;
    s.max_pixels = std::max(s.max_pixels, count[id]);
  }
}

void AddFramePixelsOnMap(const cv::Mat& masks, const cv::Mat& disparity, double f_px, double cx_px, double cy_px,
                         double baseline_m, const cv::Matx44d& enu_from_camera, const std::vector<int>& ids,
                         std::map<int, std::vector<cv::Point2d>>* points) {
  if (masks.type() != CV_16UC1 || disparity.type() != CV_32FC1 || masks.size() != disparity.size())
    throw std::invalid_argument("AddFramePixelsOnMap: needs a CV_16UC1 mask and a CV_32FC1 disparity of one size");
  std::vector<char> wanted(65536, 0);
  for (int id : ids)
    if (id > 0 && id < 65536) wanted[id] = 1;
  for (int v = 0; v < masks.rows; ++v) {
    const uint16_t* row = masks.ptr<uint16_t>(v);
    const float* d = disparity.ptr<float>(v);
    for (int u = 0; u < masks.cols; ++u) {
      if (!wanted[row[u]] || !(d[u] > 0)) continue;
      const double z = f_px * baseline_m / d[u];
      const cv::Vec4d p = enu_from_camera * cv::Vec4d((u - cx_px) * z / f_px, (v - cy_px) * z / f_px, z, 1);
      (*points)[row[u]].emplace_back(p[0], p[1]);
    }
  }
}

double LineSeenShare(const std::vector<cv::Point2d>& line, const std::vector<cv::Point2d>& seen, double tol,
                     double step) {
  if (line.size() < 2 || seen.empty()) return 0;
  // Seen points hashed on a tol grid: a sample is covered by a point in its 3 × 3 cells.
  const auto cell = [tol](const cv::Point2d& p) {
    return std::make_pair(static_cast<int64_t>(std::floor(p.x / tol)), static_cast<int64_t>(std::floor(p.y / tol)));
  };
  std::map<std::pair<int64_t, int64_t>, std::vector<cv::Point2d>> grid;
  for (const auto& p : seen) grid[cell(p)].push_back(p);
  const auto covered = [&](const cv::Point2d& q) {
    const auto [cx, cy] = cell(q);
    for (int64_t dx = -1; dx <= 1; ++dx)
      for (int64_t dy = -1; dy <= 1; ++dy)
        if (const auto it = grid.find({cx + dx, cy + dy}); it != grid.end())
          for (const auto& p : it->second)
            if (cv::norm(p - q) <= tol) return true;
    return false;
  };
  const std::vector<cv::Point2d> samples = SampleLine(line, step);
  const auto n = std::count_if(samples.begin(), samples.end(), covered);
  return static_cast<double>(n) / static_cast<double>(samples.size());
}

// The range the damage stage analysed in a frame (its detections.json); infinite when not stated.
double AnalysedRange(const fs::path& detections_json) {
  return fs::exists(detections_json) ? ReadFrameDetections(detections_json).analysed_range_m
                                     : std::numeric_limits<double>::infinity();
}

// Moves a predicted feature back by the mean placement error of the cameras that observed it; the shift.
cv::Point2d ShiftBack(PlaneFeature& f, const CameraPlacement& placement) {
  cv::Point2d sum(0, 0);
  int n = 0;
  std::vector<int64_t> frames;  // "12;13;14"
  if (const auto it = f.properties->find("observation_frames"); it != f.properties->end() && it->is_string()) {
    std::stringstream list(it->get<std::string>());
    for (std::string item; std::getline(list, item, ';');)
      if (!item.empty() && item.find_first_not_of("0123456789") == std::string::npos) frames.push_back(std::stoll(item));
  }
  for (int64_t frame : frames)
    if (const auto c = placement.by_frame.find(frame); c != placement.by_frame.end()) {
      sum += c->second;
      ++n;
    }
  const cv::Point2d shift = n > 0 ? sum / n : placement.mean;
  for (auto& ring : f.rings)
    for (auto& q : ring) q -= shift;
  for (auto& q : f.line) q -= shift;
  f.centroid -= shift;
  f.box.x -= shift.x;
  f.box.y -= shift.y;
  return shift;
}

// ---------------------------------------------------------------- scoring

DamageMapEvaluation ScoreDamageMap(const geojson::FeatureCollection& truth_fc,
                                   const geojson::FeatureCollection& predicted_fc, const EnuOrigin& origin,
                                   const TruthSightings& sightings, const DamageMapEvalOptions& o,
                                   const std::string& truth_name, const std::string& predicted_name,
                                   const CameraPlacement* placement) {
  o.Check();
  const Converter conv(origin);
  const std::vector<PlaneFeature> truth = ToPlane(truth_fc, conv, true, truth_name);
  std::vector<PlaneFeature> pred = ToPlane(predicted_fc, conv, false, predicted_name);
  std::map<int, cv::Point2d> shift_of;  // by predicted id
  if (placement)
    for (PlaneFeature& p : pred) shift_of[p.id] = ShiftBack(p, *placement);

  // Every number the scoring may read is checked up front, matched or not.
  for (const PlaneFeature& p : pred) {
    for (const char* key : {"area_m2", "sigma_area_m2", "max_depth_m", "sigma_max_depth_m", "mean_depth_m", "volume_m3",
                            "sigma_volume_m3", "max_depth_seen_m", "max_depth_bound_m", "volume_upper_m3", "length_m",
                            "width_m", "chainage_m", "offset_m"})
      Number(p, key, predicted_name);
    Flag(p, "floor_visible", predicted_name);
  }
  for (const PlaneFeature& t : truth) {
    if (t.type == "pothole")
      for (const char* key : {"mean_diameter_m", "area_m2", "max_depth_m", "volume_m3"})
        RequiredNumber(t, key, truth_name);
    if (t.type.rfind("crack_", 0) == 0) RequiredNumber(t, "length_m", truth_name);
  }
  DamageMapEvaluation e;
  e.options = o;
  if (placement) e.placement_offset_m = placement->mean;
  e.truth_path = truth_name;
  e.predicted_path = predicted_name;

  std::vector<const PlaneFeature*> t_pot, t_crack, p_pot, p_crack, p_other;
  for (const PlaneFeature& t : truth) {
    if (t.type == "pothole") {
      t_pot.push_back(&t);
    } else if (t.type.rfind("crack_", 0) == 0) {
      t_crack.push_back(&t);
    } else {
      OtherTruthCounts& c = e.other_truth[t.type];
      ++c.truth;
      const TruthSight s = SightOf(sightings, t.id);
      ++(s == TruthSight::kWhole ? c.seen : s == TruthSight::kPartial ? c.partial : c.unseen);
    }
  }
  for (const PlaneFeature& p : pred)
    (p.type == "pothole" ? p_pot : p.type == "crack" ? p_crack : p_other).push_back(&p);
  e.predicted_other = static_cast<int>(p_other.size());

  // ---- potholes
  {
    std::vector<bool> big(t_pot.size()), assignable(t_pot.size()), scored(t_pot.size());
    for (size_t j = 0; j < t_pot.size(); ++j)
      big[j] = RequiredNumber(*t_pot[j], "mean_diameter_m", truth_name) >= o.min_pothole_diameter_m;
    CountTruth(t_pot, sightings, big, &e.potholes, &assignable, &scored);
    e.potholes.predicted = static_cast<int>(p_pot.size());
    std::vector<Candidate> cand;
    std::map<std::pair<int, int>, Overlap> overlaps;
    for (size_t i = 0; i < p_pot.size(); ++i)
      for (size_t j = 0; j < t_pot.size(); ++j) {
        if (!assignable[j]) continue;
        const Overlap ov = PolygonOverlap(*p_pot[i], *t_pot[j], o.cell_m);
        if (ov.intersection_m2 <= 0 || ov.Ratio() < o.min_overlap) continue;
        overlaps[{static_cast<int>(i), static_cast<int>(j)}] = ov;
        cand.push_back({static_cast<int>(i), static_cast<int>(j), ov.Ratio(), ov.intersection_m2});
      }
    const Assignment a = Assign(cand, p_pot.size(), t_pot.size());
    std::vector<std::optional<bool>> depth_v, area_v, volume_v;
    std::vector<double> centroid, absolute_centroid, iou, depth, area, volume;
    for (size_t j = 0; j < t_pot.size(); ++j) {
      const int i = a.pred_of[j];
      if (i < 0) continue;
      const PlaneFeature& t = *t_pot[j];
      const PlaneFeature& p = *p_pot[i];
      const Overlap& ov = overlaps.at({i, static_cast<int>(j)});
      PotholeMatch m;
      m.predicted_id = p.id;
      m.truth_id = t.id;
      m.scored = scored[j];
      m.overlap = ov.Ratio();
      m.iou = ov.Iou();
      m.centroid_error_m = std::hypot(p.centroid.x - t.centroid.x, p.centroid.y - t.centroid.y);
      m.absolute_centroid_error_m = cv::norm(p.centroid + shift_of[p.id] - t.centroid);
      m.truth_max_depth_m = RequiredNumber(t, "max_depth_m", truth_name);
      m.truth_area_m2 = RequiredNumber(t, "area_m2", truth_name);
      m.truth_volume_m3 = RequiredNumber(t, "volume_m3", truth_name);
      m.max_depth_m = Number(p, "max_depth_m", predicted_name);
      m.area_m2 = Number(p, "area_m2", predicted_name);
      m.volume_m3 = Number(p, "volume_m3", predicted_name);
      m.floor_visible = Flag(p, "floor_visible", predicted_name);
      m.depth_error_mm = 1000 * (m.max_depth_m - m.truth_max_depth_m);
      if (!std::isfinite(m.depth_error_mm)) m.depth_error_mm = kNoValue;
      m.area_error_pct = PercentError(m.area_m2, m.truth_area_m2);
      m.volume_error_pct = PercentError(m.volume_m3, m.truth_volume_m3);
      const double k = o.sigma_factor;
      m.area_within_uncertainty =
          WithinSigma(m.area_m2, m.truth_area_m2, Number(p, "sigma_area_m2", predicted_name), k);
      if (m.floor_visible == false) {
        // The floor is hidden: the map states an interval for the max depth and an upper volume.
        const double lo = Number(p, "max_depth_seen_m", predicted_name);
        const double hi = Number(p, "max_depth_bound_m", predicted_name);
        if (std::isfinite(lo) || std::isfinite(hi))
          m.depth_within_uncertainty =
              (!std::isfinite(lo) || m.truth_max_depth_m >= lo) && (!std::isfinite(hi) || m.truth_max_depth_m <= hi);
        const double upper = Number(p, "volume_upper_m3", predicted_name);
        if (std::isfinite(upper)) m.volume_within_uncertainty = m.truth_volume_m3 <= upper;
      } else {
        m.depth_within_uncertainty =
            WithinSigma(m.max_depth_m, m.truth_max_depth_m, Number(p, "sigma_max_depth_m", predicted_name), k);
        m.volume_within_uncertainty =
            WithinSigma(m.volume_m3, m.truth_volume_m3, Number(p, "sigma_volume_m3", predicted_name), k);
      }
      if (m.scored) {
        ++e.potholes.matched;
        if (m.floor_visible == false) ++e.floor_hidden;
        centroid.push_back(m.centroid_error_m);
        absolute_centroid.push_back(m.absolute_centroid_error_m);
        iou.push_back(m.iou);
        depth.push_back(m.depth_error_mm);
        area.push_back(m.area_error_pct);
        volume.push_back(m.volume_error_pct);
        depth_v.push_back(m.depth_within_uncertainty);
        area_v.push_back(m.area_within_uncertainty);
        volume_v.push_back(m.volume_within_uncertainty);
      } else {
        ++e.potholes.unscored;
      }
      e.pothole_matches.push_back(m);
    }
    e.centroid_error_m = Summarise(centroid, {}, kNoValue);
    e.absolute_centroid_error_m = Summarise(absolute_centroid, {}, kNoValue);
    e.iou = Summarise(iou, {}, kNoValue);
    e.depth_error_mm = Summarise(depth, depth_v, 1000 * o.depth_tolerance_m);
    e.area_error_pct = Summarise(area, area_v, o.area_tolerance_pct);
    e.volume_error_pct = Summarise(volume, volume_v, o.volume_tolerance_pct);
    for (size_t i = 0; i < p_pot.size(); ++i) {
      if (a.truth_of[i] >= 0) continue;
      const int j = a.duplicate_of[i];
      if (j >= 0 && scored[j]) {
        ++e.potholes.duplicates;
        e.pothole_duplicates.push_back({p_pot[i]->id, t_pot[j]->id, a.score_of[i]});
      } else if (j >= 0) {
        ++e.potholes.unscored;
      } else {
        ++e.potholes.false_positives;
        e.pothole_false_positives.push_back(MakeFalse(*p_pot[i], truth, conv, predicted_name));
      }
    }
    for (size_t j = 0; j < t_pot.size(); ++j) {
      if (!scored[j] || a.pred_of[j] >= 0) continue;
      MissedDamage m;
      m.truth_id = t_pot[j]->id;
      m.frames_whole = FramesWhole(sightings, m.truth_id);
      double best = 0;
      for (const PlaneFeature* p : p_other) {
        if (!p->IsPolygon()) continue;
        const Overlap ov = PolygonOverlap(*p, *t_pot[j], o.cell_m);
        if (ov.Ratio() >= o.min_overlap && ov.intersection_m2 > best) {
          best = ov.intersection_m2;
          m.typed_otherwise_id = p->id;
          m.typed_otherwise_as = p->type;
        }
      }
      e.pothole_misses.push_back(m);
    }
    e.potholes.misses = static_cast<int>(e.pothole_misses.size());
    Finish(&e.potholes);
  }

  // ---- cracks
  {
    std::vector<bool> big(t_crack.size()), assignable(t_crack.size()), scored(t_crack.size());
    std::vector<std::vector<cv::Point2d>> samples(t_crack.size());
    for (size_t j = 0; j < t_crack.size(); ++j) {
      big[j] = RequiredNumber(*t_crack[j], "length_m", truth_name) >= o.min_crack_length_m;
      samples[j] = SampleLine(t_crack[j]->line, o.crack_sample_m);
    }
    CountTruth(t_crack, sightings, big, &e.cracks, &assignable, &scored);
    e.cracks.predicted = static_cast<int>(p_crack.size());
    std::vector<Candidate> cand;
    for (size_t i = 0; i < p_crack.size(); ++i)
      for (size_t j = 0; j < t_crack.size(); ++j) {
        if (!assignable[j] || !BoxesMeet(p_crack[i]->box, t_crack[j]->box, o.crack_tolerance_m)) continue;
        const double cov = Coverage(samples[j], *p_crack[i], o.crack_tolerance_m);
        if (cov < o.min_crack_coverage) continue;
        cand.push_back({static_cast<int>(i), static_cast<int>(j), cov, cov * t_crack[j]->length_m});
      }
    const Assignment a = Assign(cand, p_crack.size(), t_crack.size());
    std::vector<double> length, coverage;
    for (size_t j = 0; j < t_crack.size(); ++j) {
      const int i = a.pred_of[j];
      if (i < 0) continue;
      CrackMatch m;
      m.predicted_id = p_crack[i]->id;
      m.truth_id = t_crack[j]->id;
      m.scored = scored[j];
      m.coverage = a.score_of[i];
      m.truth_length_m = RequiredNumber(*t_crack[j], "length_m", truth_name);
      m.length_m = Number(*p_crack[i], "length_m", predicted_name);
      m.length_error_pct = PercentError(m.length_m, m.truth_length_m);
      if (m.scored) {
        ++e.cracks.matched;
        length.push_back(m.length_error_pct);
        coverage.push_back(m.coverage);
      } else {
        ++e.cracks.unscored;
      }
      e.crack_matches.push_back(m);
    }
    e.crack_length_error_pct = Summarise(length, {}, kNoValue);
    e.crack_coverage = Summarise(coverage, {}, kNoValue);
    for (size_t i = 0; i < p_crack.size(); ++i) {
      if (a.truth_of[i] >= 0) continue;
      const int j = a.duplicate_of[i];
      if (j >= 0 && scored[j]) {
        ++e.cracks.duplicates;
        e.crack_duplicates.push_back({p_crack[i]->id, t_crack[j]->id, a.score_of[i]});
      } else if (j >= 0) {
        ++e.cracks.unscored;
      } else {
        // A crack found within alligator cracking (not scored) is real cracking, not a false one.
        FalseDamage f = MakeFalse(*p_crack[i], truth, conv, predicted_name);
        if (f.nearest_truth_type == "alligator_cracking" && f.nearest_truth_distance_m <= o.crack_tolerance_m) {
          ++e.cracks.unscored;
          continue;
        }
        ++e.cracks.false_positives;
        e.crack_false_positives.push_back(std::move(f));
      }
    }
    for (size_t j = 0; j < t_crack.size(); ++j) {
      if (!scored[j] || a.pred_of[j] >= 0) continue;
      MissedDamage m;
      m.truth_id = t_crack[j]->id;
      m.frames_whole = FramesWhole(sightings, m.truth_id);
      double best = 0;
      std::vector<const PlaneFeature*> others = p_pot;
      others.insert(others.end(), p_other.begin(), p_other.end());
      for (const PlaneFeature* p : others) {
        if (!BoxesMeet(p->box, t_crack[j]->box, o.crack_tolerance_m)) continue;
        const double cov = Coverage(samples[j], *p, o.crack_tolerance_m);
        if (cov >= o.min_crack_coverage && cov > best) {
          best = cov;
          m.typed_otherwise_id = p->id;
          m.typed_otherwise_as = p->type;
        }
      }
      e.crack_misses.push_back(m);
    }
    e.cracks.misses = static_cast<int>(e.crack_misses.size());
    Finish(&e.cracks);
  }
  return e;
}

// ---------------------------------------------------------------- output

std::string DamageMapEvaluation::Table() const {
  const DamageMapEvalOptions& o = options;
  std::string s = fmt::format("damage map {}\n     truth {}{}\n", predicted_path, truth_path,
                              frames ? fmt::format(" (masks of {} frames)", frames) : std::string());
  s += fmt::format(
      "rules: seen = whole in a frame (>= {} px, none in the outer {} px), for cracks also >= {:g} % of the line "
      "seen by the frames together; potholes: mean diameter >= {:g} m, "
      "match = intersection / min(area) >= {:g} ({:g} mm raster); cracks: length >= {:g} m, match = >= {:g} % of "
      "the true line within {:g} m; precision = matched / (matched + duplicates + FP)\n\n",
      o.min_seen_pixels, o.border_px, 100 * o.min_line_seen, o.min_pothole_diameter_m, o.min_overlap, 1000 * o.cell_m,
      o.min_crack_length_m, 100 * o.min_crack_coverage, o.crack_tolerance_m);
  s += placement_frames > 0
           ? fmt::format("placement: the cameras' mean error E {:+.3f} N {:+.3f} m (|{:.3f}| m, {} cameras); each "
                         "damage moved back by its observing cameras' error before matching; 'abs.' keeps it\n\n",
                         placement_offset_m.x, placement_offset_m.y, cv::norm(placement_offset_m), placement_frames)
           : std::string("placement: as the map states it (no offset removed)\n\n");
  s += fmt::format("{:<9} {:>5} {:>5} {:>7} {:>5} {:>6} {:>5} {:>7} {:>8} {:>4} {:>3} {:>5} {:>6} {:>9}\n", "type",
                   "truth", "seen", "partial", "small", "unseen", "pred", "matched", "unscored", "dup", "FP", "miss",
                   "recall", "precision");
  s += CountsRow("pothole", potholes);
  s += CountsRow("crack", cracks);
  for (const auto& [type, c] : other_truth)
    s += fmt::format("{} (not scored): {} in the truth, {} seen, {} partial, {} unseen\n", type, c.truth, c.seen,
                     c.partial, c.unseen);
  if (predicted_other) s += fmt::format("{} predictions typed other (not scored)\n", predicted_other);

  if (!pothole_matches.empty()) {
    s += fmt::format(
        "\npotholes matched (errors = map − truth; 'stated': within ±{:g}σ, or where the floor is hidden, truth "
        "depth in [seen, bound] and truth volume <= upper)\n",
        o.sigma_factor);
    s += fmt::format("{:>5} {:>5} {:>7} {:>5} {:>8} {:>5} {:>8} {:>8} {:>6} {:>7} {:>6} {:>7} {:>6}  {}\n", "pred",
                     "truth", "overlap", "IoU", "centr_m", "floor", "truth_mm", "depth_mm", "stated", "area_%",
                     "stated", "vol_%", "stated", "");
    for (const PotholeMatch& m : pothole_matches)
      s += fmt::format(
          "{:>5} {:>5} {:>7.2f} {:>5.2f} {:>8.3f} {:>5} {} {} {:>6} {} {:>6} {} {:>6}  {}\n", m.predicted_id,
          m.truth_id, m.overlap, m.iou, m.centroid_error_m, m.floor_visible ? (*m.floor_visible ? "seen" : "hid") : "-",
          Fix(1000 * m.truth_max_depth_m, 1, 8), Fix(m.depth_error_mm, 1, 8), Verdict(m.depth_within_uncertainty),
          Fix(m.area_error_pct, 1, 7), Verdict(m.area_within_uncertainty), Fix(m.volume_error_pct, 1, 7),
          Verdict(m.volume_within_uncertainty), m.scored ? "" : "(unscored: partial or small)");
  }
  s += fmt::format("\npothole summary over {} scored matches ({} with the floor hidden): |error|\n", potholes.matched,
                   floor_hidden);
  s += SummaryRow("centroid m", centroid_error_m, 3, "m");
  s += SummaryRow("abs. centroid m", absolute_centroid_error_m, 3, "m");
  s += fmt::format("  {:<16} n {:>3}  median {}  min {}\n", "IoU", iou.n, Fix(iou.median_abs, 3, 7),
                   Fix(iou.min_abs, 3, 7));
  s += SummaryRow("max depth mm", depth_error_mm, 1, "mm");
  s += SummaryRow("area %", area_error_pct, 1, "%");
  s += SummaryRow("volume %", volume_error_pct, 1, "%");
  if (!pothole_misses.empty()) s += "  misses:\n" + MissLines(pothole_misses);
  for (const auto& d : pothole_duplicates)
    s += fmt::format("  duplicate: {} also on truth {} (overlap {:.2f})\n", d.predicted_id, d.truth_id, d.overlap);
  if (!pothole_false_positives.empty()) s += "  false positives:\n" + FalseLines(pothole_false_positives);

  if (!crack_matches.empty()) {
    s += "\ncracks matched\n";
    s += fmt::format("{:>5} {:>5} {:>8} {:>9} {:>9} {:>8}\n", "pred", "truth", "coverage", "truth_m", "length_m",
                     "length_%");
    for (const CrackMatch& m : crack_matches)
      s += fmt::format("{:>5} {:>5} {:>8.2f} {} {} {}  {}\n", m.predicted_id, m.truth_id, m.coverage,
                       Fix(m.truth_length_m, 2, 9), Fix(m.length_m, 2, 9), Fix(m.length_error_pct, 1, 8),
                       m.scored ? "" : "(unscored: partial or short)");
  }
  s += fmt::format("\ncrack summary over {} scored matches\n", cracks.matched);
  s += SummaryRow("length %", crack_length_error_pct, 1, "%");
  s += fmt::format("  {:<16} n {:>3}  median {}  min {}\n", "coverage", crack_coverage.n,
                   Fix(crack_coverage.median_abs, 3, 7), Fix(crack_coverage.min_abs, 3, 7));
  if (!crack_misses.empty()) s += "  misses:\n" + MissLines(crack_misses);
  for (const auto& d : crack_duplicates)
    s += fmt::format("  duplicate: {} also on truth {} (coverage {:.2f})\n", d.predicted_id, d.truth_id, d.overlap);
  if (!crack_false_positives.empty()) s += "  false positives:\n" + FalseLines(crack_false_positives);
  return s;
}

json DamageMapEvaluation::ToJson() const {
  json pm = json::array();
  for (const PotholeMatch& m : pothole_matches)
    pm.push_back({{"predicted_id", m.predicted_id},
                  {"truth_id", m.truth_id},
                  {"scored", m.scored},
                  {"overlap", m.overlap},
                  {"iou", m.iou},
                  {"centroid_error_m", m.centroid_error_m},
                  {"absolute_centroid_error_m", m.absolute_centroid_error_m},
                  {"floor_visible", Opt(m.floor_visible)},
                  {"truth",
                   {{"max_depth_m", Num(m.truth_max_depth_m)},
                    {"area_m2", Num(m.truth_area_m2)},
                    {"volume_m3", Num(m.truth_volume_m3)}}},
                  {"predicted",
                   {{"max_depth_m", Num(m.max_depth_m)}, {"area_m2", Num(m.area_m2)}, {"volume_m3", Num(m.volume_m3)}}},
                  {"depth_error_mm", Num(m.depth_error_mm)},
                  {"area_error_pct", Num(m.area_error_pct)},
                  {"volume_error_pct", Num(m.volume_error_pct)},
                  {"depth_within_uncertainty", Opt(m.depth_within_uncertainty)},
                  {"area_within_uncertainty", Opt(m.area_within_uncertainty)},
                  {"volume_within_uncertainty", Opt(m.volume_within_uncertainty)}});
  json cm = json::array();
  for (const CrackMatch& m : crack_matches)
    cm.push_back({{"predicted_id", m.predicted_id},
                  {"truth_id", m.truth_id},
                  {"scored", m.scored},
                  {"coverage", m.coverage},
                  {"truth_length_m", Num(m.truth_length_m)},
                  {"length_m", Num(m.length_m)},
                  {"length_error_pct", Num(m.length_error_pct)}});
  json other = json::object();
  for (const auto& [type, c] : other_truth)
    other[type] = {{"truth", c.truth}, {"seen", c.seen}, {"partial", c.partial}, {"unseen", c.unseen}};
  return {{"schema", "roadsurvey.eval_damage_map/1"},
          {"predicted", predicted_path},
          {"truth", truth_path},
          {"frames", frames},
          {"options", options.ToJson()},
          {"placement_offset_m",
           {{"east", placement_offset_m.x},
            {"north", placement_offset_m.y},
            {"horizontal", cv::norm(placement_offset_m)},
            {"cameras", placement_frames}}},
          {"potholes",
           {{"counts", CountsJson(potholes)},
            {"matches", pm},
            {"misses", MissesJson(pothole_misses)},
            {"duplicates", DuplicatesJson(pothole_duplicates, "overlap")},
            {"false_positives", FalseJson(pothole_false_positives)},
            {"floor_hidden", floor_hidden},
            {"summary",
             {{"centroid_error_m", SummaryJson(centroid_error_m)},
              {"absolute_centroid_error_m", SummaryJson(absolute_centroid_error_m)},
              {"iou", SummaryJson(iou)},
              {"depth_error_mm", SummaryJson(depth_error_mm)},
              {"area_error_pct", SummaryJson(area_error_pct)},
              {"volume_error_pct", SummaryJson(volume_error_pct)}}}}},
          {"cracks",
           {{"counts", CountsJson(cracks)},
            {"matches", cm},
            {"misses", MissesJson(crack_misses)},
            {"duplicates", DuplicatesJson(crack_duplicates, "coverage")},
            {"false_positives", FalseJson(crack_false_positives)},
            {"summary",
             {{"length_error_pct", SummaryJson(crack_length_error_pct)}, {"coverage", SummaryJson(crack_coverage)}}}}},
          {"other_truth", other},
          {"predicted_other", predicted_other}};
}

// ---------------------------------------------------------------- files

CameraPlacement ReadCameraPlacement(const fs::path& cameras_csv, const fs::path& truth_tum, const EnuOrigin& origin) {
  const Trajectory truth = ReadTumTrajectory(truth_tum);
  const GeographicLib::LocalCartesian enu(origin.lat_deg, origin.lon_deg, origin.h_ellipsoid_m);
  CameraPlacement out;
  cv::Point2d sum(0, 0);
  for (const EnuCamera& c : ReadOurCameras(cameras_csv, enu)) {
    if (c.frame < 0 || c.frame >= static_cast<int64_t>(truth.poses.size())) continue;
    const Eigen::Vector3d t = truth.poses[c.frame].T_world_frame.translation();
    const cv::Point2d error(c.p_enu.x() - t.x(), c.p_enu.y() - t.y());
    out.by_frame[c.frame] = error;
    sum += error;
  }
  if (!out.by_frame.empty()) out.mean = sum / static_cast<double>(out.by_frame.size());
  return out;
}

EnuOrigin ReadEnuOrigin(const fs::path& path) {
  const json j = ReadJsonFile(path);
  try {
    const json& o = j.at("origin");
    return {o.at("lat_deg").get<double>(), o.at("lon_deg").get<double>(), o.at("h_ellipsoid_m").get<double>()};
  } catch (const json::exception& e) {
    throw InputError(InputLocation::File(path.string()),
                     fmt::format("needs origin.lat_deg, origin.lon_deg and origin.h_ellipsoid_m ({})", e.what()));
  }
}

fs::path SurveyOutputDir(const fs::path& survey_dir, const fs::path& output_dir) {
  if (!output_dir.empty()) return output_dir;
  const fs::path path = survey_dir / "survey.json";
  const json j = ReadJsonFile(path);
  if (!j.is_object() || !j.contains("output") || !j["output"].is_string() || j["output"].get<std::string>().empty())
    throw InputError(InputLocation::File(path.string()), "no \"output\" folder");
  const fs::path out = j["output"].get<std::string>();
  return out.is_absolute() ? out.lexically_normal() : (survey_dir / out).lexically_normal();
}

DamageMapEvaluation EvaluateDamageMap(const fs::path& survey_dir, const fs::path& output_dir,
                                      const DamageMapEvalOptions& options) {
  options.Check();
  if (!fs::is_directory(survey_dir))
    throw InputError(InputLocation::File(survey_dir.string()),
                     "no such folder (expected one written by `roadsurvey simulate`)");
  for (const char* sub : {"left", "truth", "truth/masks"})
    if (!fs::is_directory(survey_dir / sub))
      throw InputError(InputLocation::File((survey_dir / sub).string()),
                       "missing: SURVEY must be a folder written by `roadsurvey simulate`");
  const fs::path truth_path = survey_dir / "truth/damages.geojson";
  const geojson::FeatureCollection truth = geojson::ReadFeatureCollection(truth_path);
  const EnuOrigin origin = ReadEnuOrigin(survey_dir / "truth/georeference.json");
  const fs::path output = SurveyOutputDir(survey_dir, output_dir);
  const fs::path predicted_path = output / "damage.geojson";
  if (!fs::exists(predicted_path))
    throw InputError(
        InputLocation::File(predicted_path.string()),
        fmt::format("no damage map: run `roadsurvey run {}` first", (survey_dir / "survey.json").string()));
  const geojson::FeatureCollection predicted = geojson::ReadFeatureCollection(predicted_path);

  const SimSurveyTruth survey = ReadSimSurveyTruth(survey_dir);
  // Truth cracks by id, their lines on the map: seen whole when the frames together saw the line.
  const Converter conv(origin);
  std::map<int, std::vector<cv::Point2d>> crack_lines;
  for (size_t i = 0; i < truth.features.size(); ++i) {
    const auto& f = truth.features[i];
    const auto* line = std::get_if<geojson::LineString>(&f.geometry);
    if (!line || !f.properties.is_object() || !f.properties.value("type", std::string()).starts_with("crack_")) continue;
    const TruthFeatureKey key = ReadTruthFeatureKey(f.properties, truth_path);
    for (const auto& q : line->positions) crack_lines[key.id].push_back(conv.ToEnu(q));
  }
  std::vector<int> crack_ids;
  for (const auto& [id, line] : crack_lines) crack_ids.push_back(id);
  std::vector<TruthSightings> per_frame(survey.frames.size());
  std::vector<std::map<int, std::vector<cv::Point2d>>> crack_pixels(survey.frames.size());
  const RectifiedStereo& g = survey.geometry;
  tbb::parallel_for(size_t{0}, survey.frames.size(), [&](size_t k) {
    const SimFrameTruth frame = ReadSimFrame(survey, k);
    AddFrameSightings(frame.masks, options, &per_frame[k], frame.truth_disparity_px, g.bf(),
                      AnalysedRange(output / "damage" / survey.frames[k] / "detections.json"));
    if (crack_ids.empty()) return;
    cv::Matx44d enu_from_camera;
    cv::eigen2cv(survey.trajectory.poses[k].T_world_frame.matrix(), enu_from_camera);
    AddFramePixelsOnMap(frame.masks, frame.truth_disparity_px, g.f_px, g.cx_px, g.cy_px, g.baseline_m,
                        enu_from_camera, crack_ids, &crack_pixels[k]);
  });
  TruthSightings sightings;
  for (const TruthSightings& f : per_frame)
    for (const auto& [id, s] : f) {
      TruthSighting& t = sightings[id];
      t.frames_whole += s.frames_whole;
      t.frames_partial += s.frames_partial;
      t.max_pixels = std::max(t.max_pixels, s.max_pixels);
    }
  for (const auto& [id, line] : crack_lines) {
    std::vector<cv::Point2d> seen;
    for (const auto& frame : crack_pixels)
      if (const auto it = frame.find(id); it != frame.end()) seen.insert(seen.end(), it->second.begin(), it->second.end());
    if (seen.empty()) continue;
    TruthSighting& t = sightings[id];
    t.line_seen_over_frames = LineSeenShare(line, seen, 2 * options.crack_sample_m, options.crack_sample_m);
    t.whole_over_frames = t.line_seen_over_frames >= options.min_line_seen;
  }
  // The map shares its cameras' placement error: measured on them, removed before matching.
  std::optional<CameraPlacement> placement;
  const fs::path cameras_csv = predicted_path.parent_path() / "cameras.csv";
  if (options.remove_placement_offset && fs::exists(cameras_csv))
    placement = ReadCameraPlacement(cameras_csv, survey_dir / "truth/trajectory.tum", origin);
  DamageMapEvaluation e = ScoreDamageMap(truth, predicted, origin, sightings, options, truth_path.string(),
                                         predicted_path.string(), placement ? &*placement : nullptr);
  e.placement_frames = placement ? static_cast<int>(placement->by_frame.size()) : 0;
  e.frames = static_cast<int>(survey.frames.size());
  return e;
}

}  // namespace rs
