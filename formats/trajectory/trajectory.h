#pragma once
// A trajectory as every trajectory reader returns it and the metrics consume it:
// time-ordered poses of one tracked frame in one world frame.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace rs {

/// One pose of the tracked frame at one instant.
struct StampedPose {
  /// Time in nanoseconds on the file's own time base. For inputs without times
  /// (KITTI poses without times.txt) it is the 0-based line index, see Trajectory::has_times.
  int64_t t_ns = 0;
  /// Pose of the tracked frame (camera for SLAM output, IMU body for EuRoC ground truth) in the
  /// world frame: maps points from the tracked frame into the world, so translation() is its position.
  Eigen::Isometry3d T_world_frame = Eigen::Isometry3d::Identity();
};

/// A trajectory read from one file; t_ns never decreases (a repeated time is possible: SLAM systems
/// re-emit a pose after relocalisation; association then uses the first pose of the run).
struct Trajectory {
  std::string source;     ///< the file it came from, for error messages ("" if built in memory)
  bool has_times = true;  ///< false when t_ns holds indices, not times (KITTI without times.txt)
  std::vector<StampedPose> poses;
};

}  // namespace rs
