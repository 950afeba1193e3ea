#pragma once
// Trajectory accuracy metrics: association, Umeyama alignment, ATE, RDE, RPE (TUM) and the KITTI
// odometry errors. Definitions and formulas: docs/evaluation.md, section "Trajectory metrics".
// Every function takes the estimate first and the ground truth second.

#include <cstdint>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "formats/trajectory/trajectory.h"

namespace rs {

/// Which transform is fitted between the estimate and the ground truth before absolute errors.
enum class TrajectoryAlignment {
  kNone,  ///< compare in the given frames (estimate already in the ground-truth world)
  kSE3,   ///< rotation + translation (stereo / metric SLAM)
  kSim3,  ///< rotation + translation + scale (monocular SLAM); the scale also applies to relative metrics
};
/// "none", "se3", "sim3"; nullopt otherwise.
std::optional<TrajectoryAlignment> ParseTrajectoryAlignment(std::string_view name);
const char* TrajectoryAlignmentName(TrajectoryAlignment alignment);

/// Similarity x -> scale * R * x + t that maps estimate positions onto ground-truth positions.
struct Sim3Transform {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double scale = 1.0;
  Eigen::Vector3d Apply(const Eigen::Vector3d& x) const { return scale * (R * x) + t; }
};

/// Closed-form least-squares fit of `est` onto `gt` (Umeyama 1991): minimises
/// sum_i |gt_i - (s R est_i + t)|^2 with s = 1 for kSE3, identity for kNone.
/// Throws std::invalid_argument for fewer than 3 points, different sizes, or positions that do not
/// span a plane (collinear or coincident: the rotation about the line is undetermined).
Sim3Transform UmeyamaAlignment(const Eigen::Matrix3Xd& est, const Eigen::Matrix3Xd& gt, TrajectoryAlignment alignment);

/// The estimate and ground-truth poses at the same instants, in order.
struct PosePairs {
  std::vector<int64_t> t_ns;                ///< the estimate's time (or index) of each pair
  std::vector<size_t> est_index, gt_index;  ///< where each pair came from
  std::vector<Eigen::Isometry3d> est, gt;   ///< T_world_frame of both
  size_t size() const { return est.size(); }
};

/// Pairs poses whose times differ by at most `max_difference_ns` after adding `est_offset_ns` to the
/// estimate's times. Each pose is used at most once; candidates (each pose's nearest neighbour in the
/// other trajectory) are accepted in increasing time difference, like TUM's associate.py; of poses
/// sharing a time only the first can match.
/// Throws InputError (on est.source or gt.source) when a trajectory has no times (KITTI without times.txt).
PosePairs AssociateByTimestamp(const Trajectory& est, const Trajectory& gt, int64_t max_difference_ns,
                               int64_t est_offset_ns = 0);

/// Pairs pose i with pose i. Throws InputError on est.source when the pose counts differ.
PosePairs AssociateByIndex(const Trajectory& est, const Trajectory& gt);

/// Summary statistics of a set of non-negative errors (Table I columns of the paper, plus more).
struct ErrorStats {
  size_t count = 0;  ///< 0: no value could be computed, every other field is meaningless
  double mean = 0, median = 0, rmse = 0, std = 0, min = 0, max = 0;
};
/// median of an even count is the mean of the two middle values; std is the population deviation
/// sqrt(mean((e - mean)^2)), as numpy / evo compute it.
ErrorStats ComputeErrorStats(std::vector<double> errors);

/// Absolute trajectory error after alignment.
struct AteResult {
  Sim3Transform alignment;       ///< fitted estimate -> ground truth transform
  std::vector<double> errors_m;  ///< |gt_i - S(est_i)| per pair
  ErrorStats translation_m;      ///< stats of errors_m
  ErrorStats rotation_deg;       ///< angle of R_gt_i^T * R * R_est_i per pair
};
AteResult ComputeAte(const PosePairs& pairs, TrajectoryAlignment alignment);

/// How the pairs (i, j) of a relative metric are chosen along the associated poses.
struct RelativeDelta {
  enum class Unit { kFrames, kSeconds, kMeters };
  double value = 1;  ///< > 0; whole number for kFrames
  Unit unit = Unit::kFrames;
};
/// j for each i: kFrames j = i + value; kSeconds the pose closest in time to t_i + value (skipped if
/// t_i + value is past the last pose); kMeters the first pose whose ground-truth travelled distance from
/// i reaches value. Pairs where no such j exists are skipped.
std::vector<std::pair<size_t, size_t>> RelativePairs(const PosePairs& pairs, const RelativeDelta& delta);

/// Relative distance error per pair: | s |p_est_j - p_est_i| - |p_gt_j - p_gt_i| | (s = alignment scale).
struct RdeResult {
  std::vector<double> errors_m;
  ErrorStats stats_m;
};
RdeResult ComputeRde(const PosePairs& pairs, const RelativeDelta& delta, double scale = 1.0);

/// TUM relative pose error per pair: E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) with ground truth Q, estimate P
/// (translations scaled by s); translational |trans(E)| and rotational angle(E).
struct RpeResult {
  std::vector<double> translation_m, rotation_deg;
  ErrorStats translation_stats_m, rotation_stats_deg;
};
RpeResult ComputeRpe(const PosePairs& pairs, const RelativeDelta& delta, double scale = 1.0);

/// KITTI odometry benchmark errors (devkit evaluate_odometry): for every start frame (every step_frames)
/// and length L, the first frame whose ground-truth travelled distance exceeds L; errors of the relative
/// pose divided by L, averaged over all segments.
struct KittiOdometryOptions {
  std::vector<double> lengths_m = {100, 200, 300, 400, 500, 600, 700, 800};  ///< sub-sequence lengths, > 0
  int step_frames = 10;  ///< start frames are 0, step, 2 step, ... (the devkit's value), >= 1
  /// When the ground truth is shorter than every length: use 1/10 .. 8/10 of its length instead
  /// (reported in used_lengths_m) rather than returning no segments.
  bool shorten_for_short_sequences = true;
};
struct KittiOdometryResult {
  std::vector<double> used_lengths_m;
  size_t segments = 0;            ///< 0: none fits, the averages are meaningless
  double t_err_percent = 0;       ///< mean over segments of |trans(E)| / L * 100
  double r_err_deg_per_100m = 0;  ///< mean over segments of angle(E) / L in deg per 100 m
  struct PerLength {
    double length_m = 0;
    size_t segments = 0;
    double t_err_percent = 0, r_err_deg_per_100m = 0;
  };
  std::vector<PerLength> per_length;  ///< lengths with at least one segment
};
KittiOdometryResult ComputeKittiOdometry(const PosePairs& pairs, const KittiOdometryOptions& options,
                                         double scale = 1.0);

/// Rotation angle of R in radians, robust near 0 and pi.
double RotationAngleRad(const Eigen::Matrix3d& R);

}  // namespace rs
