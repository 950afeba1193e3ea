#pragma once
// Motion-only bundle adjustment: the camera pose that minimises the Huber-robustified
// reprojection error of known 3-D points, with chi-square outlier classification between
// rounds (5.991 for 2-DoF mono, 7.815 for 3-DoF stereo residuals at 1 px sigma x pyramid scale).

#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/stereo_features.h"

namespace rs {

/// One 2-D (u_right < 0) or stereo (u, v, u_right) measurement of a known world point.
struct PoseObservation {
  Eigen::Vector3d p_world;
  double u = 0, v = 0, u_right = -1;  ///< px
  double inv_sigma2 = 1;              ///< 1 / (pyramid scale of the feature)^2
  bool outlier = false;               ///< output: classified as outlier by the last round
};

/// Chi-square 95 % thresholds used for outlier classification.
inline constexpr double kChi2Mono = 5.991, kChi2Stereo = 7.815;

/// Refines T_cam_world in place (4 rounds of Gauss-Newton, Huber kernel in the first three);
/// returns the number of inliers. Leaves the pose unchanged when fewer than 3 observations.
int OptimizePose(const RectifiedStereo& camera, std::vector<PoseObservation>* observations,
                 Eigen::Isometry3d* T_cam_world);

/// Left-multiplicative SE(3) update exp([omega, upsilon]) * T.
Eigen::Isometry3d ExpSe3Left(const Eigen::Matrix<double, 6, 1>& delta, const Eigen::Isometry3d& T);

}  // namespace rs
