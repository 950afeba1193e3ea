#include "eval/disparity/sim_disparity_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "formats/input_error.h"
#include "formats/trajectory/trajectory_file.h"
#include "formats/disparity/disparity_io.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(InputLocation::Byte(path.string(), static_cast<int64_t>(e.byte)), e.what());
  }
}

cv::Mat ReadImage(const fs::path& path, int type) {
  const cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (m.empty()) throw InputError(InputLocation::File(path.string()), "cannot read image");
  if (m.type() != type)
    throw InputError(InputLocation::File(path.string()),
                     type == CV_16UC1 ? "expected a 16-bit grey PNG" : "expected an 8-bit grey image");
  return m;
}

// The simulator's road frame (sim/ RoadGeometry, docs/simulator.md): a circular arc
// (or line) from the ENU origin with compass bearing road_heading_deg; the intact carriageway
// height is grade * s - crossfall * |l|. Only what the road mask needs: (s, l) of a world point.
struct RoadFrame {
  double heading0 = 0, curvature = 0, half_width = 0, grade = 0, crossfall = 0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();

  void ToRoad(double x, double y, double* s, double* l) const {
    const double c0 = std::cos(heading0), s0 = std::sin(heading0);
    if (curvature == 0) {
      *s = c0 * x + s0 * y, *l = -s0 * x + c0 * y;
      return;
    }
    const double vx = x - centre.x(), vy = y - centre.y(), r = std::hypot(vx, vy), rho = 1.0 / curvature;
    const double sg = rho > 0 ? 1.0 : -1.0;
    *l = rho - sg * r;
    const double nx = -vx * sg / r, ny = -vy * sg / r;  // (-sin h, cos h) at the foot point
    *s = std::atan2(-nx * c0 - ny * s0, ny * c0 - nx * s0) / curvature;
  }
  double IntactZ(double s, double l) const { return grade * s - crossfall * std::abs(l); }
};

}  // namespace

cv::Mat VisibleInRightView(const cv::Mat& gt, double tol) {
  CV_Assert(gt.type() == CV_32F);
  cv::Mat m = cv::Mat::zeros(gt.size(), CV_8U);
  for (int v = 0; v < gt.rows; ++v) {
    const float* d = gt.ptr<float>(v);
    uint8_t* out = m.ptr<uint8_t>(v);
    // Scan right to left: a nearer point further right that lands left of u - d(u) in the
    // right view hides this one.
    double min_x = std::numeric_limits<double>::infinity();
    for (int u = gt.cols - 1; u >= 0; --u) {
      if (!(d[u] > 0)) continue;
      const double x = u - d[u];
      if (x >= 0 && x <= gt.cols - 1 && x <= min_x + tol) out[u] = 255;
      min_x = std::min(min_x, x);
    }
  }
  return m;
}

std::vector<StereoPairWithTruth> LoadSimulatedSurvey(const fs::path& dir, const SimulatedPairOptions& o) {
  if (o.frame_step < 1 || o.first_frame < 0 || o.max_frames < 0)
    throw std::invalid_argument("simulated pairs: need frame_step >= 1, first_frame >= 0, max_frames >= 0");
  const fs::path scene_path = dir / "truth/scene.json";
  const nlohmann::json scene = ReadJson(scene_path);
  RoadFrame road;
  double f = 0, cx = 0, cy = 0, baseline = 0;
  int width = 0, height = 0;
  try {
    const auto& op = scene.at("options");
    if (!op.at("rectified").get<bool>())
      throw InputError(InputLocation::File(scene_path.string()), "options.rectified is false: no disparity truth");
    road.heading0 = (90.0 - op.at("road_heading_deg").get<double>()) * M_PI / 180.0;
    const double k = op.at("road_curvature_1_m").get<double>();
    road.curvature = std::abs(k) < 1e-9 ? 0.0 : k;
    road.half_width = op.at("road_width_m").get<double>() / 2;
    road.grade = op.at("road_grade").get<double>(), road.crossfall = op.at("road_crossfall").get<double>();
    if (road.curvature != 0)
      road.centre = Eigen::Vector2d(-std::sin(road.heading0), std::cos(road.heading0)) / road.curvature;
    width = op.at("image_width").get<int>(), height = op.at("image_height").get<int>();
    f = op.at("focal_px").get<double>(), baseline = op.at("baseline_m").get<double>();
    cx = op.at("cx_px").get<double>(), cy = op.at("cy_px").get<double>();
    if (cx < 0) cx = (width - 1) / 2.0;
    if (cy < 0) cy = (height - 1) / 2.0;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(InputLocation::File(scene_path.string()), std::string("options: ") + e.what());
  }

  // Pothole ids from damages.geojson.
  const fs::path damages_path = dir / "truth/damages.geojson";
  std::set<int> pothole_ids;
  const nlohmann::json damages = ReadJson(damages_path);
  try {
    for (const auto& feature : damages.at("features")) {
      const auto& p = feature.at("properties");
      if (p.at("type").get<std::string>() == "pothole") pothole_ids.insert(p.at("id").get<int>());
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(InputLocation::File(damages_path.string()), e.what());
  }

  std::vector<fs::path> lefts;
  if (!fs::is_directory(dir / "left")) throw InputError(InputLocation::File((dir / "left").string()), "no such folder");
  for (const auto& e : fs::directory_iterator(dir / "left"))
    if (e.is_regular_file()) lefts.push_back(e.path());
  std::sort(lefts.begin(), lefts.end());
  const Trajectory traj = ReadTrajectory(dir / "truth/trajectory.tum", TrajectoryFormat::kTum);
  if (traj.poses.size() != lefts.size())
    throw InputError(
        InputLocation::File((dir / "truth/trajectory.tum").string()),
        "has " + std::to_string(traj.poses.size()) + " poses for " + std::to_string(lefts.size()) + " frames");

  std::vector<StereoPairWithTruth> out;
  const std::string survey = fs::absolute(dir).lexically_normal().filename().string();
  for (size_t i = static_cast<size_t>(o.first_frame); i < lefts.size(); i += static_cast<size_t>(o.frame_step)) {
    if (o.max_frames > 0 && static_cast<int>(out.size()) >= o.max_frames) break;
    const std::string stem = lefts[i].stem().string();
    StereoPairWithTruth p;
    p.name = (survey.empty() ? "sim" : survey) + "/" + stem;
    p.left = ReadImage(lefts[i], CV_8UC1);
    p.right = ReadImage(dir / "right" / lefts[i].filename(), CV_8UC1);
    cv::Mat gt_valid;
    FromKittiDisparity16(ReadImage(dir / "truth/disparity" / (stem + ".png"), CV_16UC1), &p.gt, &gt_valid);
    const cv::Mat labels = ReadImage(dir / "truth/masks" / (stem + ".png"), CV_16UC1);
    if (p.left.cols != width || p.left.rows != height || p.right.size() != p.left.size() ||
        p.gt.size() != p.left.size() || labels.size() != p.left.size())
      throw InputError(InputLocation::File(lefts[i].string()), "image, truth and scene.json sizes differ");

    p.nonocc = VisibleInRightView(p.gt);
    p.road = cv::Mat::zeros(p.gt.size(), CV_8U);
    p.pothole = cv::Mat::zeros(p.gt.size(), CV_8U);
    const Eigen::Isometry3d& T_world_cam = traj.poses[i].T_world_frame;
    float max_d = 0;
    for (int v = 0; v < height; ++v) {
      const float* d = p.gt.ptr<float>(v);
      const uint8_t* vis = p.nonocc.ptr<uint8_t>(v);
      const uint16_t* lab = labels.ptr<uint16_t>(v);
      uint8_t* r = p.road.ptr<uint8_t>(v);
      uint8_t* ph = p.pothole.ptr<uint8_t>(v);
      for (int u = 0; u < width; ++u) {
        if (!(d[u] > 0)) continue;
        max_d = std::max(max_d, d[u]);
        if (!vis[u]) continue;
        if (lab[u] != 0) {
          if (pothole_ids.count(lab[u])) ph[u] = 255;
          continue;
        }
        const double z = f * baseline / d[u];
        const Eigen::Vector3d p_world = T_world_cam * Eigen::Vector3d((u - cx) * z / f, (v - cy) * z / f, z);
        double s = 0, l = 0;
        road.ToRoad(p_world.x(), p_world.y(), &s, &l);
        if (std::abs(l) > road.half_width - o.road_edge_margin_m) continue;
        const double tol = o.surface_tolerance_m + z * z / (f * baseline) / 512.0;
        if (std::abs(p_world.z() - road.IntactZ(s, l)) <= tol) r[u] = 255;
      }
    }
    p.min_disparity = 0;
    p.focal_px = f;
    p.num_disparities = std::min(1024, (static_cast<int>(std::ceil(max_d)) + 8 + 15) / 16 * 16);
    out.push_back(std::move(p));
  }
  if (out.empty()) throw InputError(InputLocation::File((dir / "left").string()), "no frames selected");
  return out;
}

void RoadErrorStats::Add(const RoadErrorStats& o) {
  road += o.road, road_valid += o.road_valid;
  road_over_025 += o.road_over_025, road_over_05 += o.road_over_05, road_over_1 += o.road_over_1;
  road_abs_sum += o.road_abs_sum, road_signed_sum += o.road_signed_sum, road_within_3 += o.road_within_3;
  for (size_t b = 0; b < histogram.size(); ++b) histogram[b] += o.histogram[b];
  for (int t = 0; t < 3; ++t) third_over_025[t] += o.third_over_025[t], third_valid[t] += o.third_valid[t];
  pothole += o.pothole, pothole_valid += o.pothole_valid, pothole_abs_sum += o.pothole_abs_sum;
}

double RoadErrorStats::RoadEpe() const { return road_valid ? road_abs_sum / double(road_valid) : 0; }

double RoadErrorStats::RoadSignedMean() const { return road_within_3 ? road_signed_sum / double(road_within_3) : 0; }

double RoadErrorStats::RoadShareOver(double threshold_px) const {
  if (!road_valid) return 0;
  const int64_t n = threshold_px >= 1 ? road_over_1 : threshold_px >= 0.5 ? road_over_05 : road_over_025;
  return double(n) / double(road_valid);
}

double RoadErrorStats::RoadQuantile(double q) const {
  const double target = q * double(road_valid);
  double acc = double(histogram[0]);
  if (acc >= target) return -1;
  for (int b = 0; b < kBins; ++b) {
    const double n = double(histogram[b + 1]);
    if (acc + n >= target && n > 0) return -1 + 0.05 * (b + (target - acc) / n);
    acc += n;
  }
  return 1;
}

std::string RoadErrorStats::Format() const {
  auto share = [](int64_t n, int64_t d) { return d ? 100.0 * double(n) / double(d) : 0.0; };
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "road %lld px density %.2f %% EPE %.4f signed %+.4f | >0.25 %.2f %% >0.5 %.3f %% >1 %.3f %% | "
                "q05/50/95 %+.3f %+.3f %+.3f | >0.25 by third %.2f %.2f %.2f %% | pothole %lld px MAE %.4f",
                static_cast<long long>(road), 100 * RoadDensity(), RoadEpe(), RoadSignedMean(),
                100 * RoadShareOver(0.25), 100 * RoadShareOver(0.5), 100 * RoadShareOver(1), RoadQuantile(0.05),
                RoadQuantile(0.5), RoadQuantile(0.95), share(third_over_025[0], third_valid[0]),
                share(third_over_025[1], third_valid[1]), share(third_over_025[2], third_valid[2]),
                static_cast<long long>(pothole), PotholeMae());
  return buf;
}

RoadErrorStats MeasureRoadErrors(const StereoPairWithTruth& p, const cv::Mat& disparity, const cv::Mat& valid) {
  RoadErrorStats s;
  const int W = p.gt.cols;
  for (int v = 0; v < p.gt.rows; ++v) {
    const float* g = p.gt.ptr<float>(v);
    const float* d = disparity.ptr<float>(v);
    const uint8_t* m = valid.ptr<uint8_t>(v);
    const uint8_t* road = p.road.empty() ? nullptr : p.road.ptr<uint8_t>(v);
    const uint8_t* hole = p.pothole.empty() ? nullptr : p.pothole.ptr<uint8_t>(v);
    for (int u = 0; u < W; ++u) {
      if (!(g[u] > 0)) continue;
      const double e = double(d[u]) - double(g[u]);
      if (hole && hole[u]) {
        ++s.pothole;
        if (m[u]) ++s.pothole_valid, s.pothole_abs_sum += std::abs(e);
      }
      if (!road || !road[u]) continue;
      ++s.road;
      if (!m[u]) continue;
      const double a = std::abs(e);
      const int third = std::min(2, 3 * u / W);
      ++s.road_valid, ++s.third_valid[third];
      s.road_abs_sum += a;
      if (a > 0.25) ++s.road_over_025, ++s.third_over_025[third];
      if (a > 0.5) ++s.road_over_05;
      if (a > 1) ++s.road_over_1;
      if (a <= 3) s.road_signed_sum += e, ++s.road_within_3;
      const int bin = e < -1   ? 0
                      : e >= 1 ? RoadErrorStats::kBins + 1
                               : 1 + std::min(RoadErrorStats::kBins - 1, static_cast<int>((e + 1) / 0.05));
      ++s.histogram[bin];
    }
  }
  return s;
}

void RoadBandStats::Add(const RoadBandStats& o) {
  road += o.road, valid += o.valid, within_1 += o.within_1;
  abs_sum += o.abs_sum, signed_sum += o.signed_sum, gt_sum += o.gt_sum;
  stripe_sq_sum += o.stripe_sq_sum, stripe_rows += o.stripe_rows;
}

std::vector<RoadBandStats> MeasureRoadErrorsByRows(const StereoPairWithTruth& p, const cv::Mat& disparity,
                                                   const cv::Mat& valid, const std::vector<int>& edges) {
  std::vector<RoadBandStats> bands(edges.size() < 2 ? 0 : edges.size() - 1);
  for (size_t b = 0; b < bands.size(); ++b) bands[b].row_begin = edges[b], bands[b].row_end = edges[b + 1];
  const int H = p.gt.rows, W = p.gt.cols;
  std::vector<double> row_mean(H, 0.0);
  std::vector<uint8_t> row_ok(H, 0);
  auto band_of = [&](int v) -> RoadBandStats* {
    for (auto& b : bands)
      if (v >= b.row_begin && v < b.row_end) return &b;
    return nullptr;
  };
  for (int v = 0; v < H; ++v) {
    if (p.road.empty()) break;
    const float *g = p.gt.ptr<float>(v), *d = disparity.ptr<float>(v);
    const uint8_t *m = valid.ptr<uint8_t>(v), *road = p.road.ptr<uint8_t>(v);
    RoadBandStats* b = band_of(v);
    double sum = 0;
    int64_t n = 0;
    for (int u = 0; u < W; ++u) {
      if (!road[u] || !(g[u] > 0)) continue;
      if (b) ++b->road;
      if (!m[u]) continue;
      if (b) ++b->valid;
      const double e = double(d[u]) - double(g[u]);
      if (std::abs(e) > 1) continue;
      sum += e, ++n;
      if (b) ++b->within_1, b->abs_sum += std::abs(e), b->signed_sum += e, b->gt_sum += g[u];
    }
    if (n >= RoadBandStats::kMinRowPixels) row_mean[v] = sum / double(n), row_ok[v] = 1;
  }
  for (int v = 0; v < H; ++v) {
    RoadBandStats* b = band_of(v);
    if (!b || !row_ok[v]) continue;
    double sum = 0;
    int n = 0;
    for (int y = std::max(0, v - RoadBandStats::kStripeHalf); y <= std::min(H - 1, v + RoadBandStats::kStripeHalf); ++y)
      if (row_ok[y]) sum += row_mean[y], ++n;
    const double dev = row_mean[v] - sum / n;
    b->stripe_sq_sum += dev * dev, ++b->stripe_rows;
  }
  return bands;
}

}  // namespace rs
