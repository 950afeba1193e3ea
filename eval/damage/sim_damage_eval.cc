#include "eval/damage/sim_damage_eval.h"

#include "formats/geojson/geojson.h"
#include "formats/input_error.h"
#include "stages/damage/output/damage_output.h"
#include "stages/damage/measure/measure.h"
#include "survey/stats/order_statistic.h"
#include "eval/damage/sim_truth.h"
#include "sim/road_scene.h"
#include "sim/simulation_options.h"
#include "survey/elapsed.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <iostream>
#include <map>
#include <set>
#include <stdexcept>

namespace rs {
namespace fs = std::filesystem;
namespace {

struct TruthObstacle {
  bool box = true;
  Eigen::Vector3d centre, half;
};

std::vector<TruthObstacle> ReadObstacles(const fs::path& path, const nlohmann::json& j) {
  std::vector<TruthObstacle> out;
  if (!j.contains("obstacles")) return out;
  for (const auto& o : j["obstacles"]) {
    TruthObstacle t;
    t.box = o.at("kind").get<std::string>() == "box";
    const auto c = o.at("centre_enu_m").get<std::vector<double>>();
    const auto h = o.at("half_size_m").get<std::vector<double>>();
    if (c.size() != 3 || h.size() != 3) throw InputError(InputLocation::File(path.string()), "bad obstacle");
    t.centre = {c[0], c[1], c[2]}, t.half = {h[0], h[1], h[2]};
    out.push_back(t);
  }
  return out;
}

// World point of pixel (u, v) with disparity d (px) seen from pose T_world_cam.
Eigen::Vector3d WorldPoint(const RectifiedStereo& g, const Eigen::Isometry3d& T, double u, double v, double d) {
  return T * CameraPointFromDisparity(g, u, v, d);
}

// CV_8U mask of pixels whose truth surface point lies inside an obstacle (grown by margin_m).
// Boxes are tested against their bounding cylinder (their yaw is not in scene.json) above
// the box's base plus the margin, which keeps the road around a car out of the mask.
cv::Mat ObstacleMask(const cv::Mat& truth_disp, const RectifiedStereo& g, const Eigen::Isometry3d& T,
                     const std::vector<TruthObstacle>& obstacles, double margin_m) {
  cv::Mat mask(truth_disp.size(), CV_8U, cv::Scalar(0));
  if (obstacles.empty()) return mask;
  for (int v = 0; v < truth_disp.rows; ++v)
    for (int u = 0; u < truth_disp.cols; ++u) {
      const float d = truth_disp.at<float>(v, u);
      if (!(d > 0)) continue;
      const Eigen::Vector3d p = WorldPoint(g, T, u, v, d);
      for (const auto& o : obstacles) {
        const double base = o.box ? o.centre.z() - o.half.z() : o.centre.z();
        const double radius = o.box ? std::hypot(o.half.x(), o.half.y()) : o.half.x();
        if (std::hypot(p.x() - o.centre.x(), p.y() - o.centre.y()) <= radius + margin_m && p.z() > base + margin_m) {
          mask.at<uchar>(v, u) = 255;
          break;
        }
      }
    }
  return mask;
}

double Percentile(std::vector<double> v, double q) {
  return v.empty() ? 0 : KthSmallestInPlace(v, QuantileRankNearest(q, v.size()));
}

std::string LevelLetter(SeverityLevel l) {
  switch (l) {
    case SeverityLevel::kLow: return "L";
    case SeverityLevel::kMedium: return "M";
    case SeverityLevel::kHigh: return "H";
    default: return "-";
  }
}

}  // namespace

DamageErrorStats ComputeDamageErrorStats(std::vector<double> errors) {
  DamageErrorStats s;
  s.n = static_cast<int>(errors.size());
  if (errors.empty()) return s;
  double sum = 0;
  std::vector<double> a;
  for (double e : errors) sum += e, a.push_back(std::abs(e));
  s.mean = sum / s.n;
  s.median_abs = Percentile(a, 0.5);
  s.p95_abs = Percentile(a, 0.95);
  s.max_abs = *std::max_element(a.begin(), a.end());
  return s;
}

SimDamageEvaluation EvaluateSimulatedDamage(const fs::path& dir, const SimDamageEvalOptions& o) {
  o.damage.Check();
  if (o.frame_step < 1 || o.max_frames < 0 || !(o.min_iou > 0 && o.min_iou <= 1))
    throw std::invalid_argument("EvaluateSimulatedDamage: frame_step >= 1, max_frames >= 0, 0 < min_iou <= 1");
  if (!o.use_truth_disparity) o.disparity.Check();
  const SimSurveyTruth survey = ReadSimSurveyTruth(dir);
  const RectifiedStereo& g = survey.geometry;
  const std::map<int, TruthDamage> truth = ReadTruthDamages(dir / "truth/damages.geojson");
  const std::vector<TruthObstacle> obstacles = ReadObstacles(dir / "truth/scene.json", survey.scene);
  const sim::RoadGeometry road(survey.options);

  SimDamageEvaluation r;
  const std::vector<std::string> pass_names = DamagePassNames();
  std::vector<std::vector<double>> pass_ms(pass_names.size());
  std::vector<double> ms_damage, cpu_damage, ms_disp, road_abs_mm, depth_mm, visible_depth_mm, area_pct, volume_pct,
      visible_volume_pct, seen_depth_mm, seen_volume_pct, bound_ratio, volume_ratio, hidden_depth_est_mm,
      bounded_volume_est_pct;
  int within = 0, severity_ok = 0, area_within = 0, volume_within = 0;
  double sigma_sum = 0, valid_sum = 0, sigma_area_pct_sum = 0, sigma_volume_pct_sum = 0;
  std::set<int> unique;
  for (size_t k = 0; k < survey.frames.size(); k += o.frame_step) {
    if (o.max_frames > 0 && r.frames >= o.max_frames) break;
    const std::string& name = survey.frames[k];
    const SimFrameTruth frame = ReadSimFrame(survey, k);
    const cv::Mat &left = frame.left, &masks = frame.masks, &truth_disp = frame.truth_disparity_px;
    cv::Mat disparity = truth_disp, sharp;
    if (!o.use_truth_disparity) {
      const cv::Mat right = ReadSimRightImage(survey, k);
      const auto t0 = std::chrono::steady_clock::now();
      DisparityParams dp = o.disparity;
      dp.camera_focal_px = g.f_px;  // as the disparity stage takes it from the calibration
      DisparityResult dr = ComputeDisparity(left, right, dp);
      ms_disp.push_back(MsSince(t0));
      disparity = dr.disparity;
      if (o.use_sharp_disparity) sharp = dr.disparity_sharp;
    }
    valid_sum += cv::countNonZero(disparity > 0) / double(disparity.total());
    r.width = left.cols, r.height = left.rows;
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    const FrameDamage fd = DetectDamage(disparity, left, g, o.damage, sharp);
    // Scored range: as asked, else the range the damage stage analysed in this frame.
    const double max_range = o.max_range_m > 0 ? o.max_range_m : fd.analysed_range_m;
    r.max_range_m = std::max(r.max_range_m, max_range);
    cpu_damage.push_back(1000.0 * double(std::clock() - c0) / CLOCKS_PER_SEC);
    ms_damage.push_back(MsSince(t0));
    for (size_t j = 0; j < pass_names.size(); ++j) pass_ms[j].push_back(fd.PassMs(pass_names[j]));
    ++r.frames;

    const Eigen::Isometry3d& T = survey.trajectory.poses[k].T_world_frame;
    const cv::Mat obstacle = ObstacleMask(truth_disp, g, T, obstacles, o.obstacle_margin_m);

    // Overlaps, areas, border contact, obstacle share: one pass over the frame.
    std::map<int, long long> area_p, area_t, on_damage_p, on_obstacle_p;
    std::map<int, double> z_sum_t, z_max_t, visible_depth_t, visible_volume_t;
    const Eigen::Vector3d cam = T.translation();
    std::map<std::pair<int, int>, long long> inter;
    std::set<int> border_p, border_t;
    const cv::Mat road_ok = fd.relief.valid_mask & (fd.relief.obstacle_mask == 0) & (obstacle == 0);
    for (int v = 0; v < masks.rows; ++v) {
      const uint16_t* tr = masks.ptr<uint16_t>(v);
      const uint16_t* pr = fd.labels.ptr<uint16_t>(v);
      const bool edge_row = v == 0 || v == masks.rows - 1;
      for (int u = 0; u < masks.cols; ++u) {
        const int t = tr[u], p = pr[u];
        // The frame's border is the stereo pair's: a point left of the right image (u − d < 0,
        // true disparity) is seen by the left camera alone, and no stereo matcher measures it.
        const float d_true = truth_disp.at<float>(v, u);
        const bool edge = edge_row || u == 0 || u == masks.cols - 1 || (d_true > 0 && u - d_true < 0);
        if (t) {
          ++area_t[t];
          if (const float d = truth_disp.at<float>(v, u); d > 0) {
            const double z = g.f_px * g.baseline_m / d;
            z_sum_t[t] += z;
            z_max_t[t] = std::max(z_max_t[t], z);
            // Depth of the seen surface point below the intact road.
            const Eigen::Vector3d p = WorldPoint(g, T, u, v, d);
            double s_road, l_road;
            road.ToRoad(p.x(), p.y(), &s_road, &l_road);
            const double below = road.IntactZ(s_road, l_road) - p.z();
            visible_depth_t[t] = std::max(visible_depth_t[t], below);
            // The pixel's area on the intact road: where its ray meets the road (Newton steps
            // on the ray parameter, the road's slope is small), Z³/(f²·h) with h the camera's
            // height above the road's tangent plane there.
            const Eigen::Vector3d ray = p - cam;
            double lambda = 1, dz_ds = 0, dz_dl = 0, cos_h = 1, sin_h = 0;
            Eigen::Vector3d q = p;
            for (int it = 0; it < 4; ++it) {
              q = cam + lambda * ray;
              road.ToRoad(q.x(), q.y(), &s_road, &l_road);
              lambda -= (q.z() - road.IntactZ(s_road, l_road)) / ray.z();
            }
            q = cam + lambda * ray;
            road.ToRoad(q.x(), q.y(), &s_road, &l_road, &cos_h, &sin_h);
            const double zq = road.IntactZ(s_road, l_road, &dz_ds, &dz_dl);
            const Eigen::Vector2d grad = dz_ds * Eigen::Vector2d(cos_h, sin_h) + dz_dl * Eigen::Vector2d(-sin_h, cos_h);
            const double h = (cam.z() - zq - grad.dot(cam.head<2>() - q.head<2>())) / std::sqrt(1 + grad.squaredNorm());
            const double z_cam = lambda * z;
            if (h > 0) visible_volume_t[t] += std::max(0.0, below) * z_cam * z_cam * z_cam / (g.f_px * g.f_px * h);
          }
          if (edge) border_t.insert(t);
          // Hidden in part behind a nearer obstacle (a parked car): cut like at the border.
          if (!edge && !border_t.count(t)) {
            const float d = truth_disp.at<float>(v, u);
            for (const cv::Point n :
                 {cv::Point(u - 1, v), cv::Point(u + 1, v), cv::Point(u, v - 1), cv::Point(u, v + 1)})
              if (obstacle.at<uchar>(n) && truth_disp.at<float>(n) > d) border_t.insert(t);
          }
        }
        if (p) {
          ++area_p[p];
          if (edge) border_p.insert(p);
          if (t) ++on_damage_p[p], ++inter[{p, t}];
          if (obstacle.at<uchar>(v, u)) ++on_obstacle_p[p];
        }
        // Road model: the true intact road's height relative to the fitted surface.
        if (!t && (u % 4 == 0) && (v % 4 == 0) && road_ok.at<uchar>(v, u) && truth_disp.at<float>(v, u) > 0) {
          const Eigen::Vector3d pc = CameraPointFromDisparity(g, u, v, truth_disp.at<float>(v, u));
          road_abs_mm.push_back(std::abs(1000.0 * fd.surface.DepthBelow(pc) - fd.relief.correction_mm.at<float>(v, u)));
        }
      }
    }
    // Scored: potholes wide enough, wholly in the frame and in the analysed range (a pothole
    // reaching beyond it is cut like one at the image border), deep enough to be confirmed at
    // their range by the stage's stated σ_Z rule.
    auto in_view = [&](int t) {
      const auto it = truth.find(t);
      return it != truth.end() && it->second.type == "pothole" && it->second.mean_diameter_m >= o.min_diameter_m &&
             !border_t.count(t) && z_max_t[t] <= max_range;
    };
    auto confirmable = [&](int t) {
      const double sigma_z = StereoDepthSigma(z_sum_t[t] / area_t[t], o.damage.measure.sigma_disparity_px, g);
      return !o.require_confirmable_depth ||
             truth.at(t).max_depth_m >= o.damage.measure.pothole_min_depth_sigma * sigma_z;
    };
    auto scored = [&](int t) { return in_view(t) && confirmable(t); };
    std::map<int, const DamageInstance*> pothole_det;
    bool debug_frame = false;
    for (const auto& d : fd.instances) {
      if (on_obstacle_p[d.id] * 2 >= area_p[d.id] && area_p[d.id] > 0) {
        ++r.obstacle_detections;
        const cv::Rect box = cv::boundingRect(fd.labels == d.id);
        r.obstacle_detection_lines.push_back(
            fmt::format("{} #{} {}: {:.4f} m2, {:.1f} mm deep, Z {:.1f} m, {:.0f} % on obstacle, bbox {}x{}+{}+{}",
                        name, d.id, DamageTypeName(d.type), d.area_m2, 1000 * d.max_depth_m, d.range_m,
                        100.0 * on_obstacle_p[d.id] / area_p[d.id], box.width, box.height, box.x, box.y));
        debug_frame = true;
      }
      if (d.type == DamageType::kPothole) pothole_det[d.id] = &d;
    }
    // Greedy one-to-one matching by descending IoU between pothole detections and scored truth.
    std::vector<std::tuple<double, int, int>> pairs;
    for (const auto& [key, n] : inter) {
      if (!pothole_det.count(key.first) || !scored(key.second)) continue;
      const double iou = double(n) / double(area_p[key.first] + area_t[key.second] - n);
      if (iou >= o.min_iou) pairs.emplace_back(iou, key.first, key.second);
    }
    std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
    std::map<int, std::pair<int, double>> match_of_truth;  // truth id -> (detection id, IoU)
    std::set<int> matched_p;
    for (const auto& [iou, p, t] : pairs) {
      if (matched_p.count(p) || match_of_truth.count(t)) continue;
      matched_p.insert(p);
      match_of_truth[t] = {p, iou};
    }
    for (const auto& [p, d] : pothole_det) {
      if (border_p.count(p) && !matched_p.count(p)) continue;  // cut by the frame: not scored
      ++r.detections;
      r.hidden_flag_detections += !d->floor_visible;
      if (matched_p.count(p)) continue;
      if (on_damage_p[p] * 2 >= area_p[p]) {
        // Mostly on truth damage: either unscored damage (ignored) or a poor segmentation of a
        // scored pothole (counted false).
        long long on_scored = 0;
        for (const auto& [key, n] : inter)
          if (key.first == p && scored(key.second)) on_scored += n;
        if (on_scored * 2 < on_damage_p[p]) {
          ++r.ignored_detections;
          continue;
        }
      }
      ++r.false_positives;
      const cv::Rect box = cv::boundingRect(fd.labels == p);
      r.false_detections.push_back(fmt::format(
          "{} #{}: {:.4f} m2, {:.1f} mm deep (mean {:.1f}), Z {:.1f} m, {:.0f} % on damage, bbox {}x{}+{}+{}", name, p,
          d->area_m2, 1000 * d->max_depth_m, 1000 * d->mean_depth_m, d->range_m, 100.0 * on_damage_p[p] / area_p[p],
          box.width, box.height, box.x, box.y));
      debug_frame = true;
    }
    for (const auto& [t, n] : area_t) {
      if (in_view(t) && !confirmable(t)) ++r.unconfirmable;
      if (!scored(t)) continue;
      const TruthDamage& td = truth.at(t);
      PotholeObservation ob;
      ob.frame = name, ob.truth_id = t;
      ob.truth_max_depth_m = td.max_depth_m, ob.truth_area_m2 = td.area_m2, ob.truth_volume_m3 = td.volume_m3;
      ob.truth_severity = td.severity;
      ob.range_m = z_sum_t[t] / n;
      ob.truth_visible_depth_m = visible_depth_t[t];
      ob.truth_visible_volume_m3 = visible_volume_t[t];
      unique.insert(t);
      if (const auto m = match_of_truth.find(t); m != match_of_truth.end()) {
        const DamageInstance& d = *pothole_det.at(m->second.first);
        ob.detected = true, ob.iou = m->second.second;
        ob.max_depth_m = d.max_depth_m, ob.area_m2 = d.area_m2, ob.volume_m3 = d.volume_m3;
        ob.max_depth_seen_m = d.max_depth_seen_m, ob.volume_seen_m3 = d.volume_seen_m3;
        ob.sigma_depth_m = d.sigma_depth_m, ob.astm = d.astm.level;
        ob.sigma_area_m2 = d.sigma_area_m2, ob.sigma_volume_m3 = d.sigma_volume_m3;
        area_within += std::abs(d.area_m2 - td.area_m2) <= 2 * d.sigma_area_m2;
        sigma_area_pct_sum += 100.0 * d.sigma_area_m2 / d.area_m2;
        ++r.detected;
        const double de = d.max_depth_m - td.max_depth_m;
        depth_mm.push_back(1000.0 * de);
        visible_depth_mm.push_back(1000.0 * (d.max_depth_seen_m - ob.truth_visible_depth_m));
        ob.truth_floor_hidden = td.max_depth_m - ob.truth_visible_depth_m > 0.010;
        r.occluded += ob.truth_floor_hidden;
        // The stage's line-of-sight verdict: where it says seen, the accuracy bounds apply;
        // where it says hidden, the truth must lie within the interval it states, and its
        // estimate is scored apart.
        ob.floor_visible = d.floor_visible;
        ob.max_depth_bound_m = d.max_depth_bound_m, ob.volume_upper_m3 = d.volume_upper_m3;
        r.flag_agreements += d.floor_visible != ob.truth_floor_hidden;
        r.flagged_hidden_truth_seen += !d.floor_visible && !ob.truth_floor_hidden;
        r.flagged_seen_truth_hidden += d.floor_visible && ob.truth_floor_hidden;
        if (d.floor_visible) {
          seen_depth_mm.push_back(1000.0 * de);
        } else {
          ++r.hidden_matches;
          r.hidden_depth_contained +=
              td.max_depth_m >= d.max_depth_seen_m - 2 * d.sigma_depth_m && td.max_depth_m <= d.max_depth_bound_m;
          bound_ratio.push_back(d.max_depth_bound_m / td.max_depth_m);
          hidden_depth_est_mm.push_back(1000.0 * de);
        }
        // The volume likewise: an upper bound is stated wherever the rim's shadow may hide some.
        if (!std::isfinite(d.volume_upper_m3)) {
          seen_volume_pct.push_back(100.0 * (d.volume_m3 - td.volume_m3) / td.volume_m3);
          volume_within += std::abs(d.volume_m3 - td.volume_m3) <= 2 * d.sigma_volume_m3;
          sigma_volume_pct_sum += 100.0 * d.sigma_volume_m3 / d.volume_m3;
        } else {
          ++r.volume_bounded_matches;
          r.hidden_volume_contained +=
              td.volume_m3 >= d.volume_seen_m3 - 2 * d.sigma_depth_m * d.area_m2 && td.volume_m3 <= d.volume_upper_m3;
          volume_ratio.push_back(d.volume_upper_m3 / td.volume_m3);
          bounded_volume_est_pct.push_back(100.0 * (d.volume_m3 - td.volume_m3) / td.volume_m3);
        }
        if (ob.truth_visible_volume_m3 > 0)
          visible_volume_pct.push_back(100.0 * (d.volume_seen_m3 - ob.truth_visible_volume_m3) /
                                       ob.truth_visible_volume_m3);
        area_pct.push_back(100.0 * (d.area_m2 - td.area_m2) / td.area_m2);
        volume_pct.push_back(100.0 * (d.volume_m3 - td.volume_m3) / td.volume_m3);
        within += std::abs(de) <= 2.0 * d.sigma_depth_m;
        sigma_sum += d.sigma_depth_m;
        severity_ok += LevelLetter(d.astm.level) == td.severity;
      }
      debug_frame |= !ob.detected;
      if (!ob.detected && !o.debug_dir.empty())
        for (const auto& [key, n2] : inter)
          if (key.second == t) {
            const auto it = std::find_if(fd.instances.begin(), fd.instances.end(),
                                         [&](const DamageInstance& d) { return d.id == key.first; });
            std::cerr << name << " missed " << t << " (" << n << " px): overlaps #" << key.first << " by " << n2
                      << " px of " << area_p[key.first] << ", type " << DamageTypeName(it->type) << ", depth "
                      << it->max_depth_m << "\n";
          }
      r.observations.push_back(ob);
    }
    if ((debug_frame || o.debug_all_frames) && !o.debug_dir.empty()) {
      fs::create_directories(o.debug_dir);
      cv::Mat overlay = RenderOverlay(left, fd.labels, fd.instances);
      for (const auto& [t, n] : area_t) {
        std::vector<std::vector<cv::Point>> contours;
        cv::findContours(masks == t, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
        cv::drawContours(overlay, contours, -1, scored(t) ? cv::Scalar(0, 255, 0) : cv::Scalar(255, 255, 0), 1);
      }
      cv::imwrite((o.debug_dir / (name + ".png")).string(), overlay);
      cv::Mat depth8;
      fd.relief.depth_below_mm.convertTo(depth8, CV_8U, 5.0, 128.0);  // 0.2 mm per grey level, road = 128
      cv::imwrite((o.debug_dir / (name + "_depth.png")).string(), depth8);
      std::cerr << name << ": threshold " << fd.threshold_sigma << " sigma, road sigma "
                << fd.surface.residual_sigma_m * 1000 << " mm, height " << fd.surface.camera_height_m << " m\n";
    }
  }
  r.unique_potholes = static_cast<int>(unique.size());
  r.recall = r.observations.empty() ? 0.0 : double(r.detected) / r.observations.size();
  const int tp = r.detections - r.ignored_detections - r.false_positives;
  r.precision = tp + r.false_positives > 0 ? double(tp) / (tp + r.false_positives) : 0.0;
  r.depth_error_mm = ComputeDamageErrorStats(depth_mm);
  r.visible_depth_error_mm = ComputeDamageErrorStats(visible_depth_mm);
  r.visible_volume_error_pct = ComputeDamageErrorStats(visible_volume_pct);
  r.area_error_pct = ComputeDamageErrorStats(area_pct);
  r.seen_depth_error_mm = ComputeDamageErrorStats(seen_depth_mm);
  r.seen_volume_error_pct = ComputeDamageErrorStats(seen_volume_pct);
  r.hidden_bound_ratio = ComputeDamageErrorStats(bound_ratio);
  r.volume_upper_ratio = ComputeDamageErrorStats(volume_ratio);
  r.hidden_depth_estimate_error_mm = ComputeDamageErrorStats(hidden_depth_est_mm);
  r.bounded_volume_estimate_error_pct = ComputeDamageErrorStats(bounded_volume_est_pct);
  r.volume_error_pct = ComputeDamageErrorStats(volume_pct);
  if (r.detected > 0) {
    r.depth_within_2sigma = double(within) / r.detected;
    r.mean_sigma_depth_mm = 1000.0 * sigma_sum / r.detected;
    r.severity_agreement = double(severity_ok) / r.detected;
    r.area_within_2sigma = double(area_within) / r.detected;
    r.mean_sigma_area_pct = sigma_area_pct_sum / r.detected;
  }
  if (!seen_volume_pct.empty()) {
    r.volume_within_2sigma = double(volume_within) / seen_volume_pct.size();
    r.mean_sigma_volume_pct = sigma_volume_pct_sum / seen_volume_pct.size();
  }
  r.road_median_abs_mm = Percentile(road_abs_mm, 0.5);
  r.disparity_valid_fraction = r.frames ? valid_sum / r.frames : 0.0;
  r.ms_damage_median = Percentile(ms_damage, 0.5);
  r.ms_damage_max = ms_damage.empty() ? 0 : *std::max_element(ms_damage.begin(), ms_damage.end());
  r.ms_disparity_median = Percentile(ms_disp, 0.5);
  r.cpu_ms_damage_median = Percentile(cpu_damage, 0.5);
  for (size_t j = 0; j < pass_names.size(); ++j)
    r.pass_ms_median.push_back({pass_names[j], Percentile(pass_ms[j], 0.5)});
  return r;
}

std::string SimDamageEvaluation::Report() const {
  auto stats = [](const DamageErrorStats& s, const char* unit) {
    return fmt::format("bias {:+.1f}{u}, median |e| {:.1f}{u}, p95 {:.1f}{u}, max {:.1f}{u} (n {})", s.mean,
                       s.median_abs, s.p95_abs, s.max_abs, s.n, fmt::arg("u", unit));
  };
  std::string passes;
  for (const PassTime& p : pass_ms_median)
    passes += fmt::format("{}{} {:.1f}", passes.empty() ? "" : ", ", p.name, p.ms);
  std::string s = fmt::format(
      "{} frames {}x{}, disparity valid {:.1f} %, scored range <= {:.1f} m\n"
      "potholes scored: {} observations of {} potholes; recall {:.3f} ({}/{}); in view but below the sigma_Z rule: {}\n"
      "pothole detections {}: false {}, on unscored damage {}; precision {:.3f}\n"
      "obstacle pixels reported as damage: {} detections\n"
      "max depth error (estimate): {}; within 2 sigma_Z {:.1f} % (mean sigma_Z {:.1f} mm)\n"
      "seen max depth error against the depth visible in the frame: {}; floor hidden (> 10 mm) in {} matches\n"
      "area error: {}\nvolume error (estimate): {}\nseen volume error against the volume visible in the frame: {}\n"
      "floor seen (stage) in {} matches: max depth error {}\n"
      "floor hidden (stage) in {} matches: true depth in [seen - 2 sigma_Z, bound] {}/{}; bound / true depth {}; "
      "estimate error {}\n"
      "volume seen (stage: no upper bound) in {} matches: volume error {}\n"
      "volume bounded (stage) in {} matches: true volume in [seen - 2 sigma_Z area, upper] {}/{}; upper / true {}; "
      "estimate error {}\n"
      "hidden flag vs truth (floor hidden > 10 mm): agrees in {}/{} matches, flagged hidden but seen {}, flagged "
      "seen but hidden {}; pothole detections flagged hidden {}/{}\n"
      "severity (ASTM vs truth) agreement {:.1f} %\n"
      "stated uncertainty: area within 2 sigma_area {:.1f} % (mean sigma_area {:.1f} % of the area); volume seen "
      "within 2 sigma_volume {:.1f} % (mean sigma_volume {:.1f} %, n {})\n"
      "road model: median |true road - fitted| {:.2f} mm\n"
      "time per frame: DetectDamage median {:.1f} ms wall (max {:.1f}), {:.1f} ms CPU ({}); "
      "disparity median {:.1f} ms",
      frames, width, height, 100 * disparity_valid_fraction, max_range_m, observations.size(), unique_potholes, recall,
      detected, observations.size(), unconfirmable, detections, false_positives, ignored_detections, precision,
      obstacle_detections, stats(depth_error_mm, " mm"), 100 * depth_within_2sigma, mean_sigma_depth_mm,
      stats(visible_depth_error_mm, " mm"), occluded, stats(area_error_pct, " %"), stats(volume_error_pct, " %"),
      stats(visible_volume_error_pct, " %"), seen_depth_error_mm.n, stats(seen_depth_error_mm, " mm"), hidden_matches,
      hidden_depth_contained, hidden_matches,
      fmt::format("median {:.2f}, max {:.2f}", hidden_bound_ratio.median_abs, hidden_bound_ratio.max_abs),
      stats(hidden_depth_estimate_error_mm, " mm"), seen_volume_error_pct.n, stats(seen_volume_error_pct, " %"),
      volume_bounded_matches, hidden_volume_contained, volume_bounded_matches,
      fmt::format("median {:.2f}, max {:.2f}", volume_upper_ratio.median_abs, volume_upper_ratio.max_abs),
      stats(bounded_volume_estimate_error_pct, " %"), flag_agreements, detected, flagged_hidden_truth_seen,
      flagged_seen_truth_hidden, hidden_flag_detections, detections, 100 * severity_agreement, 100 * area_within_2sigma,
      mean_sigma_area_pct, 100 * volume_within_2sigma, mean_sigma_volume_pct, seen_volume_error_pct.n,
      road_median_abs_mm, ms_damage_median, ms_damage_max, cpu_ms_damage_median, passes, ms_disparity_median);
  return s;
}

}  // namespace rs
