#pragma once
// Changing which rigid frame a trajectory tracks, e.g. to compare EuRoC ground truth (IMU body B)
// with a camera-frame estimate: T_world_cam = T_world_body * T_body_cam, with T_body_cam = T_BS of
// cam0/sensor.yaml.

#include <Eigen/Geometry>

#include "formats/trajectory/trajectory.h"

namespace rs {

/// Returns the trajectory of a frame rigidly attached to the tracked one: every pose becomes
/// T_world_frame * T_frame_new (T_frame_new = pose of the new frame in the tracked frame).
Trajectory ApplyExtrinsic(const Trajectory& trajectory, const Eigen::Isometry3d& T_frame_new);

}  // namespace rs
