#pragma once
// Putting a bundle adjustment's result back into the SLAM world frame, and carrying the frames
// that are not keyframes along with their keyframes.

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "formats/trajectory/trajectory.h"

namespace rs {

enum class GaugeAnchor {
  kFirstKeyframe,  ///< the first keyframe keeps its SLAM pose exactly
  kKeyframes,      ///< the rigid motion that best maps all refined keyframe poses onto the SLAM ones
};

/// The world-side rigid motion G with G * T_world_cam_refined[i] ≈ T_world_cam_slam[i]. kKeyframes:
/// rotation the chordal mean of R_slam_i R_refined_iᵀ (well defined on a straight road, where
/// positions alone leave the roll about the road undetermined), translation matching the centroids
/// of the positions. No scale: the rig's fixed baseline fixes it.
Eigen::Isometry3d GaugeTransform(const std::vector<Eigen::Isometry3d>& T_world_cam_slam,
                                 const std::vector<Eigen::Isometry3d>& T_world_cam_refined, GaugeAnchor anchor);

/// SE(3) logarithm (rho, phi) and exponential: the geodesic used for interpolation.
Eigen::Matrix<double, 6, 1> LogSE3(const Eigen::Isometry3d& T);
Eigen::Isometry3d ExpSE3(const Eigen::Matrix<double, 6, 1>& xi);

/// A keyframe's correction C = T_world_cam_refined * T_world_cam_slam⁻¹ at its time.
struct KeyframeCorrection {
  int64_t t_ns = 0;
  Eigen::Isometry3d C = Eigen::Isometry3d::Identity();
};

/// Every pose of `slam` moved by the correction at its time: C(t) = C0 exp(a log(C0⁻¹ C1)) with
/// a = (t - t0) / (t1 - t0) between the bracketing keyframes (by time), the nearest keyframe's
/// correction before the first and after the last. A keyframe's own pose becomes exactly its
/// refined pose; a frame keeps its pose relative to a keyframe at the same instant.
Trajectory CarryTrajectory(const Trajectory& slam, std::vector<KeyframeCorrection> corrections);

}  // namespace rs
