#pragma once
// One call from two trajectories to every metric, as `roadsurvey eval trajectory EST GT` reports it:
// a JSON document for machines and a fixed-width table for people.

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "eval/trajectory/trajectory_metrics.h"

namespace rs {

/// Everything EvaluateTrajectory can be told; defaults follow the TUM and KITTI tools.
struct TrajectoryEvalOptions {
  TrajectoryAlignment alignment = TrajectoryAlignment::kSE3;  ///< fitted before ATE; its scale feeds RDE/RPE/KITTI
  bool associate_by_index = false;                            ///< pair pose i with pose i (KITTI) instead of by time
  int64_t max_time_difference_ns = 20'000'000;  ///< timestamp association tolerance (TUM default 0.02 s), >= 0
  int64_t est_time_offset_ns = 0;               ///< added to the estimate's times before association
  RelativeDelta rde_delta{1, RelativeDelta::Unit::kFrames};  ///< RDE pair spacing
  RelativeDelta rpe_delta{1, RelativeDelta::Unit::kFrames};  ///< RPE pair spacing (TUM default: 1 frame)
  KittiOdometryOptions kitti;                                ///< KITTI odometry t_err / r_err settings
  size_t min_matched_poses = 3;                              ///< fewer matches than this is an error, >= 3

  /// Empty when valid, else the rule broken, e.g. "max_time_difference_ns = -1 violates >= 0".
  std::string Check() const;
};

/// Results of EvaluateTrajectory; statistics with count 0 could not be computed (see warnings).
struct TrajectoryEvalReport {
  std::string est_source, gt_source;
  size_t est_poses = 0, gt_poses = 0, matched_poses = 0;
  TrajectoryEvalOptions options;
  AteResult ate;
  RdeResult rde;
  RpeResult rpe;
  KittiOdometryResult kitti;
  std::vector<std::string> warnings;  ///< e.g. unmatched poses, no KITTI segment
};

/// Associates, aligns and computes ATE, RDE, RPE and KITTI errors. Throws std::invalid_argument on invalid
/// options (Check()), InputError (naming the estimate file) when too few poses match or alignment is
/// impossible (collinear positions).
TrajectoryEvalReport EvaluateTrajectory(const Trajectory& est, const Trajectory& gt,
                                        const TrajectoryEvalOptions& options);

/// Machine-readable report (schema in docs/evaluation.md); counts 0 become null statistics.
nlohmann::json TrajectoryEvalReportToJson(const TrajectoryEvalReport& report);

/// Human-readable table: one row per metric with count, mean, median, RMSE, STD, min, max.
std::string FormatTrajectoryEvalTable(const TrajectoryEvalReport& report);

}  // namespace rs
