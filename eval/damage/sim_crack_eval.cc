#include "eval/damage/sim_crack_eval.h"

#include "formats/geojson/geojson.h"
#include "formats/input_error.h"
#include "stages/damage/measure/measure.h"
#include "survey/stats/order_statistic.h"
#include "eval/damage/sim_truth.h"
#include "survey/atomic_file.h"
#include "sim/road_scene.h"
#include "sim/simulation_options.h"

#include <GeographicLib/LocalCartesian.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

namespace rs {
namespace fs = std::filesystem;
namespace {

struct TruthCrack {
  bool linear = false;  // longitudinal or transverse (scored); else alligator (not scored)
  double width_m = 0, length_m = 0;
  std::vector<Eigen::Vector3d> centreline_world;  // linear cracks only
};

// Truth cracks by id, centrelines in the simulation's world frame (local ENU; the height of
// the intact road, which the GeoJSON leaves out).
std::map<int, TruthCrack> ReadTruthCracks(const fs::path& dir, const sim::RoadGeometry& road) {
  const fs::path geo_path = dir / "truth/georeference.json";
  const nlohmann::json geo = ReadJsonFile(geo_path);
  double lat0 = 0, lon0 = 0, h0 = 0;
  try {
    lat0 = geo.at("origin").at("lat_deg").get<double>();
    lon0 = geo.at("origin").at("lon_deg").get<double>();
    h0 = geo.at("origin").at("h_ellipsoid_m").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(InputLocation::File(geo_path.string()), e.what());
  }
  const GeographicLib::LocalCartesian enu(lat0, lon0, h0);
  const fs::path path = dir / "truth/damages.geojson";
  const geojson::FeatureCollection fc = geojson::ReadFeatureCollection(path);
  std::map<int, TruthCrack> out;
  for (const auto& f : fc.features) {
    const auto& p = f.properties;
    const auto [id, type] = ReadTruthFeatureKey(p, path);
    const bool linear = type == "crack_longitudinal" || type == "crack_transverse";
    if (!linear && type != "alligator_cracking") continue;
    TruthCrack c;
    c.linear = linear;
    c.width_m = p.contains("width_m") && p["width_m"].is_number() ? p["width_m"].get<double>() : 0.0;
    if (linear) {
      const auto* line = std::get_if<geojson::LineString>(&f.geometry);
      if (!line || !p.contains("length_m") || !p["length_m"].is_number() || !(c.width_m > 0))
        throw InputError(InputLocation::File(path.string()),
                         fmt::format("crack {} needs a LineString, width_m and length_m", id));
      c.length_m = p["length_m"].get<double>();
      for (const auto& q : line->positions) {
        double x, y, z, s, l;
        enu.Forward(q.lat_deg, q.lon_deg, h0, x, y, z);
        road.ToRoad(x, y, &s, &l);
        c.centreline_world.emplace_back(x, y, road.IntactZ(s, l));
      }
    }
    out[id] = std::move(c);
  }
  return out;
}

double Median(std::vector<double> v) { return v.empty() ? 0 : LowerMedianInPlace(v); }

// The part of a centreline seen in this frame, sampled every 5 mm: a sample counts when it
// projects into the image, lies within the analysed range and the truth surface there is not
// nearer (not hidden behind an obstacle or a crest). Returns its length and mean camera depth
// and draws it with `id` into `centre` (1 px) and `body` (the crack's width in pixels at that
// depth, at least 1 px). The simulator's masks cannot serve as the truth here: they hold only the
// crack's floor, which an oblique ray misses (it meets the far wall of a 30 mm-deep groove).
struct Visible {
  double length_m = 0, range_m = 0;
  double width_px = 0;  // mean width across the crack in the image
};

Visible DrawVisible(const TruthCrack& c, int id, const Eigen::Isometry3d& T_world_cam, const RectifiedStereo& g,
                    const cv::Mat& truth_disp, double max_range_m, cv::Mat& centre, cv::Mat& body) {
  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  const std::vector<Eigen::Vector3d>& line = c.centreline_world;
  double length = 0, z_sum = 0, w_sum = 0;
  bool have_prev = false;
  cv::Point prev;
  for (size_t k = 0; k + 1 < line.size(); ++k) {
    const double seg = (line[k + 1] - line[k]).norm();
    const int n = std::max(1, static_cast<int>(std::ceil(seg / 0.005)));
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = T_cam_world * (line[k] + (line[k + 1] - line[k]) * ((i + 0.5) / n));
      bool seen = p.z() > 0 && p.z() <= max_range_m;
      cv::Point q;
      if (seen) {
        q = cv::Point(static_cast<int>(std::lround(g.f_px * p.x() / p.z() + g.cx_px)),
                      static_cast<int>(std::lround(g.f_px * p.y() / p.z() + g.cy_px)));
        seen = q.x >= 1 && q.y >= 1 && q.x < truth_disp.cols - 1 && q.y < truth_disp.rows - 1;
      }
      if (seen) {
        const float d = truth_disp.at<float>(q);
        seen = d > 0 && g.f_px * g.baseline_m / d >= p.z() - 0.1;  // nothing nearer in front
      }
      if (!seen) {
        have_prev = false;
        continue;
      }
      // Width across the crack in the image: its two edges on the road, projected.
      const Eigen::Vector3d dir = (line[k + 1] - line[k]).normalized();
      const Eigen::Vector3d across = dir.cross(Eigen::Vector3d::UnitZ()).normalized() * (0.5 * c.width_m);
      const Eigen::Vector3d mid = line[k] + (line[k + 1] - line[k]) * ((i + 0.5) / n);
      const Eigen::Vector3d e1 = T_cam_world * (mid + across), e2 = T_cam_world * (mid - across);
      const double w_img =
          std::hypot(g.f_px * (e1.x() / e1.z() - e2.x() / e2.z()), g.f_px * (e1.y() / e1.z() - e2.y() / e2.z()));
      length += seg / n;
      z_sum += p.z() * seg / n;
      w_sum += w_img * seg / n;
      const int w_px = std::max(1, static_cast<int>(std::lround(w_img)));
      const cv::Point from = have_prev ? prev : q;
      cv::line(centre, from, q, cv::Scalar(id), 1, cv::LINE_8);
      cv::line(body, from, q, cv::Scalar(id), w_px, cv::LINE_8);
      prev = q, have_prev = true;
    }
  }
  Visible out;
  out.length_m = length;
  if (length > 0) out.range_m = z_sum / length, out.width_px = w_sum / length;
  return out;
}

}  // namespace

SimCrackEvaluation EvaluateSimulatedCracks(const fs::path& dir, const SimCrackEvalOptions& o) {
  o.damage.Check();
  if (o.frame_step < 1 || o.max_frames < 0 || o.tolerance_px < 0 || !(o.min_visible_length_m >= 0) ||
      !(o.min_coverage > 0 && o.min_coverage <= 1) || !(o.min_detection_share > 0 && o.min_detection_share <= 1))
    throw std::invalid_argument(
        "EvaluateSimulatedCracks: frame_step >= 1, max_frames >= 0, tolerance_px >= 0, min_visible_length_m >= 0, "
        "0 < min_coverage <= 1, 0 < min_detection_share <= 1");
  if (!o.use_truth_disparity) o.disparity.Check();
  const SimSurveyTruth survey = ReadSimSurveyTruth(dir);
  const RectifiedStereo& g = survey.geometry;
  const sim::RoadGeometry road(survey.options);
  const std::map<int, TruthCrack> truth = ReadTruthCracks(dir, road);

  SimCrackEvaluation r;
  r.min_width_px = o.min_width_px;
  std::set<int> unique;
  std::vector<double> ms_cracks, length_pct, width_mm;
  double false_area = 0, false_length = 0;
  const cv::Mat band = cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * o.tolerance_px + 1, 2 * o.tolerance_px + 1});
  for (size_t k = 0; k < survey.frames.size(); k += o.frame_step) {
    if (o.max_frames > 0 && r.frames >= o.max_frames) break;
    const std::string& name = survey.frames[k];
    const SimFrameTruth frame = ReadSimFrame(survey, k);
    const cv::Mat &left = frame.left, &masks = frame.masks, &truth_disp = frame.truth_disparity_px;
    cv::Mat disparity = truth_disp;
    if (!o.use_truth_disparity) {
      DisparityParams dp = o.disparity;
      dp.camera_focal_px = g.f_px;  // as the disparity stage takes it from the calibration
      disparity = ComputeDisparity(left, ReadSimRightImage(survey, k), dp).disparity;
    }
    const FrameDamage fd = DetectDamage(disparity, left, g, o.damage);
    ms_cracks.push_back(fd.PassMs("cracks"));
    ++r.frames;
    const double max_range = fd.analysed_range_m;
    const double z_far = std::isfinite(max_range) ? max_range : 1e9;

    // Truth: linear cracks drawn from their centrelines (scored), alligator areas from the masks
    // (tolerated: detections there are not false, but they are not scored).
    const Eigen::Isometry3d& T = survey.trajectory.poses[k].T_world_frame;
    cv::Mat linear_t = cv::Mat::zeros(masks.size(), CV_16U), body_t = cv::Mat::zeros(masks.size(), CV_16U);
    std::map<int, Visible> seen;
    for (const auto& [id, c] : truth)
      if (c.linear) seen[id] = DrawVisible(c, id, T, g, truth_disp, z_far, linear_t, body_t);
    for (const auto& [id, vis] : seen)  // unresolvable cracks: detections there are right, misses not counted
      if (vis.width_px < o.min_width_px) linear_t.setTo(0, linear_t == id);
    cv::Mat any_t = body_t != 0;
    for (int v = 0; v < masks.rows; ++v) {
      const uint16_t* m = masks.ptr<uint16_t>(v);
      uchar* a = any_t.ptr<uchar>(v);
      for (int u = 0; u < masks.cols; ++u)
        if (m[u] && truth.count(m[u])) a[u] = 255;
    }
    std::set<int> crack_ids;
    for (const DamageInstance& d : fd.instances)
      if (d.type == DamageType::kCrack) crack_ids.insert(d.id);
    cv::Mat detected = cv::Mat::zeros(masks.size(), CV_8U);
    for (int v = 0; v < masks.rows; ++v) {
      const uint16_t* l = fd.labels.ptr<uint16_t>(v);
      for (int u = 0; u < masks.cols; ++u)
        if (l[u] && crack_ids.count(l[u])) detected.at<uchar>(v, u) = 255;
    }
    cv::Mat detected_band, any_band, linear_band;
    cv::dilate(detected, detected_band, band);
    cv::dilate(any_t, any_band, band);
    cv::dilate(body_t, linear_band, band);  // grey dilation: cracks lie ≥ 0.15 m apart, ids do not mix
    const cv::Mat area = PixelAreaOnRoad(fd.relief, g, fd.surface);

    // Pixels: truth found, detections on truth; per truth crack its pixels and those found;
    // per detection its pixels per truth crack.
    std::map<int, long long> t_pixels, t_found, d_pixels;
    std::map<int, std::map<int, long long>> d_on;  // detection -> truth id (0: none) -> pixels
    std::map<int, long long> d_on_any;
    std::map<int, double> d_false_area;  // road-plane area of a detection's pixels off every truth crack
    for (int v = 0; v < masks.rows; ++v) {
      const uint16_t* lt = linear_t.ptr<uint16_t>(v);
      const uint16_t* lb = linear_band.ptr<uint16_t>(v);
      const uint16_t* lab = fd.labels.ptr<uint16_t>(v);
      const uchar* db = detected_band.ptr<uchar>(v);
      const uchar* det = detected.ptr<uchar>(v);
      const uchar* ab = any_band.ptr<uchar>(v);
      const float* a = area.ptr<float>(v);
      for (int u = 0; u < masks.cols; ++u) {
        if (lt[u]) {
          ++r.truth_pixels, ++t_pixels[lt[u]];
          if (db[u]) ++r.truth_pixels_found, ++t_found[lt[u]];
        }
        if (det[u]) {
          ++r.detected_pixels, ++d_pixels[lab[u]], ++d_on[lab[u]][lb[u]];
          if (ab[u])
            ++r.detected_pixels_on_truth, ++d_on_any[lab[u]];
          else if (std::isfinite(a[u]))
            d_false_area[lab[u]] += a[u];
        }
      }
    }
    // Detections: assigned to the truth crack holding most of their pixels, if enough.
    std::map<int, std::vector<const DamageInstance*>> assigned;
    for (const DamageInstance& d : fd.instances) {
      if (d.type != DamageType::kCrack) continue;
      ++r.detections;
      int best = 0;
      long long best_n = 0;
      for (const auto& [t, n] : d_on[d.id])
        if (t && n > best_n) best = t, best_n = n;
      if (best && best_n >= o.min_detection_share * d_pixels[d.id]) {
        assigned[best].push_back(&d);
      } else if (d_on_any[d.id] < o.min_detection_share * d_pixels[d.id]) {
        ++r.false_detections;  // on no truth crack, linear or alligator
        if (std::isfinite(d.length_m)) false_length += d.length_m;
      }
    }
    for (const auto& [id, a] : d_false_area) false_area += a;

    // Truth cracks seen in this frame.
    for (const auto& [id, c] : truth) {
      if (!c.linear) continue;
      const Visible& vis = seen[id];
      const double visible = vis.length_m;
      if (visible < o.min_visible_length_m) continue;
      if (vis.width_px < o.min_width_px) {  // narrower than a pixel in this view: not resolvable
        ++r.unresolved;
        continue;
      }
      if (t_pixels[id] == 0) continue;
      CrackObservation ob;
      ob.frame = name, ob.truth_id = id, ob.truth_width_m = c.width_m, ob.truth_length_m = c.length_m;
      ob.visible_length_m = visible, ob.range_m = vis.range_m, ob.width_px = vis.width_px;
      ob.coverage = double(t_found[id]) / double(t_pixels[id]);
      ob.detected = ob.coverage >= o.min_coverage;
      if (ob.detected) {
        ++r.detected;
        double len = 0, wlen = 0;
        for (const DamageInstance* d : assigned[id])
          if (std::isfinite(d->length_m) && std::isfinite(d->mean_width_m))
            len += d->length_m, wlen += d->length_m * d->mean_width_m;
        if (len > 0) {
          ob.length_m = len, ob.mean_width_m = wlen / len;
          length_pct.push_back(100.0 * (len - visible) / visible);
          width_mm.push_back(1000.0 * (ob.mean_width_m - c.width_m));
        }
      }
      unique.insert(id);
      r.observations.push_back(ob);
    }

    if (!o.debug_dir.empty()) {
      fs::create_directories(o.debug_dir);
      cv::Mat overlay;
      cv::cvtColor(left, overlay, cv::COLOR_GRAY2BGR);
      overlay.setTo(cv::Scalar(255, 0, 255), (fd.labels != 0) & (detected == 0));  // depressions
      overlay.setTo(cv::Scalar(0, 200, 0), linear_t != 0);
      overlay.setTo(cv::Scalar(0, 220, 255), (detected != 0) & (any_band != 0));
      overlay.setTo(cv::Scalar(0, 0, 255), (detected != 0) & (any_band == 0));
      cv::imwrite((o.debug_dir / (name + "_cracks.png")).string(), overlay);
    }
  }
  r.pixel_precision = r.detected_pixels ? double(r.detected_pixels_on_truth) / double(r.detected_pixels) : 1.0;
  r.pixel_recall = r.truth_pixels ? double(r.truth_pixels_found) / double(r.truth_pixels) : 0.0;
  r.pixel_f1 = r.pixel_precision + r.pixel_recall > 0
                   ? 2 * r.pixel_precision * r.pixel_recall / (r.pixel_precision + r.pixel_recall)
                   : 0.0;
  r.unique_cracks = static_cast<int>(unique.size());
  r.instance_recall = r.observations.empty() ? 0.0 : double(r.detected) / double(r.observations.size());
  r.false_area_m2_per_frame = r.frames ? false_area / r.frames : 0.0;
  r.false_length_m_per_frame = r.frames ? false_length / r.frames : 0.0;
  r.length_error_pct = ComputeDamageErrorStats(length_pct);
  r.width_error_mm = ComputeDamageErrorStats(width_mm);
  r.ms_cracks_median = Median(ms_cracks);
  return r;
}

std::string SimCrackEvaluation::Report(bool per_observation) const {
  auto stats = [](const DamageErrorStats& s) {
    return fmt::format("n {} mean {:+.1f} median|.| {:.1f} p95|.| {:.1f} max|.| {:.1f}", s.n, s.mean, s.median_abs,
                       s.p95_abs, s.max_abs);
  };
  std::string out = fmt::format(
      "frames {}: crack pixels P {:.3f} R {:.3f} F1 {:.3f} (truth {} px, detected {} px)\n"
      "instances: {} observations of {} cracks ({} more narrower than {} px not scored), found {} (recall {:.3f}); "
      "detections {}, false {} "
      "({:.3f} m2 and {:.2f} m of false crack per frame)\n"
      "length error % (found): {}\nwidth error mm (found): {}\ncrack step median {:.1f} ms\n",
      frames, pixel_precision, pixel_recall, pixel_f1, truth_pixels, detected_pixels, observations.size(),
      unique_cracks, unresolved, min_width_px, detected, instance_recall, detections, false_detections,
      false_area_m2_per_frame, false_length_m_per_frame, stats(length_error_pct), stats(width_error_mm),
      ms_cracks_median);
  if (per_observation)
    for (const CrackObservation& ob : observations)
      out += fmt::format(
          "  {} crack {}: width {:.1f} mm ({:.1f} px), visible {:.2f} of {:.2f} m at {:.1f} m, coverage {:.2f}{}\n",
          ob.frame, ob.truth_id, 1000 * ob.truth_width_m, ob.width_px, ob.visible_length_m, ob.truth_length_m,
          ob.range_m, ob.coverage,
          std::isfinite(ob.length_m)
              ? fmt::format(" -> length {:.2f} m, width {:.1f} mm", ob.length_m, 1000 * ob.mean_width_m)
              : (ob.detected ? " found (no metric measurement)" : " missed"));
  return out;
}

}  // namespace rs
