#pragma once
// Up-directions from the road: robust planes through the SLAM map points along the track.
// A road is level across its width within its crossfall (a cambered road falls both ways from
// the crown, so a plane across the whole carriageway is level), so the normal of the road plane
// under the cameras is the vertical, in the SLAM world, up to grade along the track — which a
// rotation about the track axis does not see.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace rs {

struct RoadPlaneOptions {
  double window_m = 10;          ///< track length whose points make one plane, m
  double max_range_m = 20;       ///< points further than this from the window's cameras are ignored, m
  double tolerance_m = 0.10;     ///< plane inlier distance: above the camber's rise across a lane, m
  double max_axis_tilt_deg = 20; ///< a plane tilted more than this along the track is not the road
  int min_inliers = 30;          ///< fewer inliers: no plane for the window
  int ransac_iterations = 300;   ///< 3-point plane hypotheses per window
  uint64_t seed = 1;             ///< sampling seed
};

/// One road plane: its upward normal (towards the cameras) and support, SLAM world.
struct RoadPlane {
  Eigen::Vector3d up_slam = Eigen::Vector3d::UnitZ();
  int inliers = 0;
  int points = 0;
  double rms_m = 0;  ///< inlier distance RMS
};

/// Planes along the track: windows of `window_m` along `axis_slam` (unit), each from the map
/// points near that window's camera centres. Windows without a good plane are left out.
std::vector<RoadPlane> FitRoadPlanes(const std::vector<Eigen::Vector3d>& points_slam,
                                     const std::vector<Eigen::Vector3d>& camera_centres_slam,
                                     const Eigen::Vector3d& axis_slam, const RoadPlaneOptions& options);

}  // namespace rs
