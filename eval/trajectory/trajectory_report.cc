#include "eval/trajectory/trajectory_report.h"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "formats/input_error.h"

namespace rs {

namespace {

const char* UnitName(RelativeDelta::Unit unit) {
  switch (unit) {
    case RelativeDelta::Unit::kFrames: return "frames";
    case RelativeDelta::Unit::kSeconds: return "s";
    case RelativeDelta::Unit::kMeters: return "m";
  }
  return "?";
}

std::string CheckDelta(const char* name, const RelativeDelta& d) {
  if (!(d.value > 0) || !std::isfinite(d.value)) return fmt::format("{}.value = {} violates value > 0", name, d.value);
  if (d.unit == RelativeDelta::Unit::kFrames && d.value != std::floor(d.value)) {
    return fmt::format("{}.value = {} violates value is a whole number of frames", name, d.value);
  }
  return {};
}

nlohmann::json StatsJson(const ErrorStats& s) {
  if (s.count == 0) return nullptr;
  return {{"count", s.count}, {"mean", s.mean}, {"median", s.median}, {"rmse", s.rmse},
          {"std", s.std},     {"min", s.min},   {"max", s.max}};
}

nlohmann::json DeltaJson(const RelativeDelta& d) { return {{"value", d.value}, {"unit", UnitName(d.unit)}}; }

std::string StatsRow(const char* name, const ErrorStats& s) {
  if (s.count == 0) return fmt::format("{:<24} {:>7} {:>10}\n", name, 0, "n/a");
  return fmt::format("{:<24} {:>7} {:>10.4f} {:>10.4f} {:>10.4f} {:>10.4f} {:>10.4f} {:>10.4f}\n", name, s.count,
                     s.mean, s.median, s.rmse, s.std, s.min, s.max);
}

}  // namespace

std::string TrajectoryEvalOptions::Check() const {
  if (max_time_difference_ns < 0) {
    return fmt::format("max_time_difference_ns = {} violates max_time_difference_ns >= 0", max_time_difference_ns);
  }
  if (min_matched_poses < 3)
    return fmt::format("min_matched_poses = {} violates min_matched_poses >= 3", min_matched_poses);
  if (std::string e = CheckDelta("rde_delta", rde_delta); !e.empty()) return e;
  if (std::string e = CheckDelta("rpe_delta", rpe_delta); !e.empty()) return e;
  if (kitti.step_frames < 1) return fmt::format("kitti.step_frames = {} violates step_frames >= 1", kitti.step_frames);
  for (double L : kitti.lengths_m) {
    if (!(L > 0) || !std::isfinite(L)) return fmt::format("kitti.lengths_m contains {} which violates length > 0", L);
  }
  return {};
}

TrajectoryEvalReport EvaluateTrajectory(const Trajectory& est, const Trajectory& gt,
                                        const TrajectoryEvalOptions& options) {
  if (std::string error = options.Check(); !error.empty()) throw std::invalid_argument("trajectory eval: " + error);
  TrajectoryEvalReport r;
  r.options = options;
  r.est_source = est.source;
  r.gt_source = gt.source;
  r.est_poses = est.poses.size();
  r.gt_poses = gt.poses.size();
  const PosePairs pairs = options.associate_by_index ? AssociateByIndex(est, gt)
                                                     : AssociateByTimestamp(est, gt, options.max_time_difference_ns,
                                                                            options.est_time_offset_ns);
  r.matched_poses = pairs.size();
  if (pairs.size() < options.min_matched_poses) {
    throw InputError(
        InputLocation::File(est.source),
        fmt::format("only {} of {} poses matched a ground-truth pose in {} (need {}){}", pairs.size(), est.poses.size(),
                    gt.source, options.min_matched_poses,
                    options.associate_by_index ? "" : "; check time bases, --max-time-diff and --time-offset"));
  }
  size_t repeated = 0;
  for (size_t i = 1; i < est.poses.size(); ++i) repeated += est.poses[i].t_ns == est.poses[i - 1].t_ns;
  if (repeated && !options.associate_by_index) {
    r.warnings.push_back(
        fmt::format("{} estimate poses repeat the previous pose's time; only the first is matched", repeated));
  }
  if (pairs.size() < est.poses.size()) {
    r.warnings.push_back(fmt::format("{} of {} estimate poses have no ground-truth match and are not evaluated",
                                     est.poses.size() - pairs.size(), est.poses.size()));
  }
  try {
    r.ate = ComputeAte(pairs, options.alignment);
  } catch (const std::invalid_argument& e) {
    throw InputError(InputLocation::File(est.source), e.what());
  }
  const double scale = r.ate.alignment.scale;
  r.rde = ComputeRde(pairs, options.rde_delta, scale);
  r.rpe = ComputeRpe(pairs, options.rpe_delta, scale);
  r.kitti = ComputeKittiOdometry(pairs, options.kitti, scale);
  if (r.rde.stats_m.count == 0) r.warnings.push_back("RDE: no pose pair at the requested spacing");
  if (r.rpe.translation_stats_m.count == 0) r.warnings.push_back("RPE: no pose pair at the requested spacing");
  if (r.kitti.segments == 0) {
    r.warnings.push_back("KITTI odometry: no sub-sequence of the requested lengths fits the ground truth");
  } else if (r.kitti.used_lengths_m != options.kitti.lengths_m) {
    r.warnings.push_back(
        "KITTI odometry: ground truth shorter than every requested length; used 1/10..8/10 of its length");
  }
  return r;
}

nlohmann::json TrajectoryEvalReportToJson(const TrajectoryEvalReport& r) {
  const TrajectoryEvalOptions& o = r.options;
  nlohmann::json j;
  j["estimate"] = {{"path", r.est_source}, {"poses", r.est_poses}};
  j["ground_truth"] = {{"path", r.gt_source}, {"poses", r.gt_poses}};
  j["matched_poses"] = r.matched_poses;
  j["options"] = {{"alignment", TrajectoryAlignmentName(o.alignment)},
                  {"association", o.associate_by_index ? "index" : "timestamp"},
                  {"max_time_difference_s", o.max_time_difference_ns * 1e-9},
                  {"est_time_offset_s", o.est_time_offset_ns * 1e-9},
                  {"rde_delta", DeltaJson(o.rde_delta)},
                  {"rpe_delta", DeltaJson(o.rpe_delta)},
                  {"kitti",
                   {{"lengths_m", o.kitti.lengths_m},
                    {"step_frames", o.kitti.step_frames},
                    {"shorten_for_short_sequences", o.kitti.shorten_for_short_sequences}}}};
  const Sim3Transform& a = r.ate.alignment;
  nlohmann::json rotation = nlohmann::json::array();
  for (int row = 0; row < 3; ++row) rotation.push_back({a.R(row, 0), a.R(row, 1), a.R(row, 2)});
  j["alignment"] = {{"rotation", rotation}, {"translation_m", {a.t.x(), a.t.y(), a.t.z()}}, {"scale", a.scale}};
  j["ate_m"] = StatsJson(r.ate.translation_m);
  j["ate_rotation_deg"] = StatsJson(r.ate.rotation_deg);
  j["rde_m"] = StatsJson(r.rde.stats_m);
  j["rpe_translation_m"] = StatsJson(r.rpe.translation_stats_m);
  j["rpe_rotation_deg"] = StatsJson(r.rpe.rotation_stats_deg);
  nlohmann::json kitti = {{"lengths_m", r.kitti.used_lengths_m}, {"segments", r.kitti.segments}};
  kitti["t_err_percent"] = r.kitti.segments ? nlohmann::json(r.kitti.t_err_percent) : nlohmann::json(nullptr);
  kitti["r_err_deg_per_100m"] = r.kitti.segments ? nlohmann::json(r.kitti.r_err_deg_per_100m) : nlohmann::json(nullptr);
  kitti["per_length"] = nlohmann::json::array();
  for (const auto& p : r.kitti.per_length) {
    kitti["per_length"].push_back({{"length_m", p.length_m},
                                   {"segments", p.segments},
                                   {"t_err_percent", p.t_err_percent},
                                   {"r_err_deg_per_100m", p.r_err_deg_per_100m}});
  }
  j["kitti"] = kitti;
  j["warnings"] = r.warnings;
  return j;
}

std::string FormatTrajectoryEvalTable(const TrajectoryEvalReport& r) {
  const TrajectoryEvalOptions& o = r.options;
  std::string s;
  s += fmt::format("estimate:     {} ({} poses)\n", r.est_source, r.est_poses);
  s += fmt::format("ground truth: {} ({} poses)\n", r.gt_source, r.gt_poses);
  s += fmt::format("matched:      {} poses by {}\n", r.matched_poses, o.associate_by_index ? "index" : "timestamp");
  s += fmt::format("alignment:    {} (scale {:.6f})\n", TrajectoryAlignmentName(o.alignment), r.ate.alignment.scale);
  s += fmt::format("\n{:<24} {:>7} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}\n", "metric", "count", "mean", "median",
                   "rmse", "std", "min", "max");
  s += StatsRow("ATE [m]", r.ate.translation_m);
  s += StatsRow("ATE rotation [deg]", r.ate.rotation_deg);
  s += StatsRow(fmt::format("RDE [m] ({:g} {})", o.rde_delta.value, UnitName(o.rde_delta.unit)).c_str(), r.rde.stats_m);
  s += StatsRow(fmt::format("RPE trans [m] ({:g} {})", o.rpe_delta.value, UnitName(o.rpe_delta.unit)).c_str(),
                r.rpe.translation_stats_m);
  s += StatsRow("RPE rot [deg]", r.rpe.rotation_stats_deg);
  if (r.kitti.segments) {
    s += fmt::format("\nKITTI odometry: t_err {:.4f} %  r_err {:.4f} deg/100m  ({} segments)\n", r.kitti.t_err_percent,
                     r.kitti.r_err_deg_per_100m, r.kitti.segments);
    for (const auto& p : r.kitti.per_length) {
      s += fmt::format("  {:>8.1f} m: t_err {:.4f} %  r_err {:.4f} deg/100m  ({} segments)\n", p.length_m,
                       p.t_err_percent, p.r_err_deg_per_100m, p.segments);
    }
  } else {
    s += "\nKITTI odometry: n/a (no sub-sequence fits)\n";
  }
  for (const std::string& w : r.warnings) s += "warning: " + w + "\n";
  return s;
}

}  // namespace rs
