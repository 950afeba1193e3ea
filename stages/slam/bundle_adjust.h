#pragma once
// Ceres bundle adjustment of a local window of the SLAM map and SE(3) pose-graph optimisation for
// loop closing (the global BA after loop closing is global_refinement.h). Poses are parametrised
// as (angle-axis, translation) of T_cam_world; residuals are whitened by the pyramid-level sigma.

#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/slam_map.h"

namespace rs {

/// Stereo (u, v, u_right) or mono (u, v) reprojection residual, for ceres::AutoDiffCostFunction.
/// pose = (angle-axis[3], t[3]) of T_cam_world, point = p_world[3].
struct ReprojectionResidual {
  double u, v, u_right;  ///< measurement, px (u_right < 0: mono, third residual is zero)
  double fx, fy, cx, cy, baseline_m;
  double sqrt_info;  ///< 1 / sigma of the feature's pyramid level

  template <typename T>
  bool operator()(const T* pose, const T* point, T* residual) const;
};

/// [v]_x, the cross-product matrix: Skew(v) x = v × x.
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);

/// R(w) of an angle-axis vector and its left Jacobian Jl(w) (d(R(w) x)/dw = -[R x]_x Jl(w)); first
/// order near w = 0, as ceres::AngleAxisRotatePoint. Shared by the analytic reprojection Jacobians.
void AngleAxisWithLeftJacobian(const Eigen::Vector3d& w, Eigen::Matrix3d* R, Eigen::Matrix3d* Jl);

/// ReprojectionResidual's residual with analytic Jacobians (row-major 3x6 w.r.t. the pose, 3x3 w.r.t.
/// the point; either may be null): the local and global BA use it, ~3x cheaper than autodiff;
/// bundle_adjust_test checks it against the autodiff Jacobians.
void EvaluateReprojection(const ReprojectionResidual& r, const double* pose, const double* point, double* residual,
                          double* J_pose, double* J_point);

/// A pose's rotation R(w) and left Jacobian Jl(w), computed once for all of its observations.
struct PoseRotation {
  Eigen::Matrix3d R, Jl;
  explicit PoseRotation(const double* pose);
};

/// EvaluateReprojection with the pose's rotation given (t = the pose's translation): the same
/// arithmetic, so the same bits, without the angle-axis trigonometry per observation.
void EvaluateReprojection(const ReprojectionResidual& r, const PoseRotation& rotation, const double* t,
                          const double* point, double* residual, double* J_pose, double* J_point);

/// Relative-pose residual of a pose-graph edge (6 residuals: rotation angle-axis, translation),
/// poses = (angle-axis[3], t[3]) of T_world_kf.
struct RelativePoseResidual {
  Eigen::Quaterniond q_a_b;  ///< measured rotation of b in a
  Eigen::Vector3d t_a_b;     ///< measured position of b in a, m
  double weight_rotation = 1, weight_translation = 1;

  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* residual) const;
};

/// What a bundle adjustment did.
struct BundleAdjustSummary {
  int keyframes = 0, fixed_keyframes = 0, points = 0, observations = 0;
  int outliers_removed = 0;
  double initial_cost = 0, final_cost = 0;
};

/// Optimises the poses of `free_kfs` and the points they observe; every other keyframe observing
/// those points is held fixed. With remove_outliers, observations above the chi-square threshold are
/// erased afterwards (and the problem re-solved once without them). fixed_size: solve windows of
/// <= 40 poses with SolveSmallBundle (bundle_adjust_solver.h) instead of Ceres.
BundleAdjustSummary BundleAdjust(SlamMap* map, const std::vector<int>& free_kfs, const RectifiedStereo& camera,
                                 const ScalePyramid& pyramid, int iterations, bool remove_outliers,
                                 const std::vector<int>& fixed_kfs_extra = {}, bool fixed_size = false);

/// One pose-graph edge: measured T_a_b between keyframes a and b.
struct PoseGraphEdge {
  int a = 0, b = 0;
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  double weight = 1;
};

/// Optimises T_world_kf of every node except `fixed` (held) given relative-pose edges.
void OptimizePoseGraph(std::vector<Eigen::Isometry3d>* T_world_kf, const std::vector<PoseGraphEdge>& edges,
                       const std::vector<int>& fixed, int iterations);

}  // namespace rs

#include "stages/slam/bundle_adjust_impl.h"
