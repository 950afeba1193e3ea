#pragma once
// Georeferencing of a SLAM trajectory on plain data (no files): the GNSS fit (gnss_fit.h), the
// roll about the track axis from attitude or road planes (road_plane.h), residuals, and every
// frame's camera pose in a local ENU frame. The stage (georeference_stage.h) reads the inputs
// and writes the outputs around it.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "stages/georeference/gnss_fit.h"
#include "stages/georeference/road_plane.h"

namespace rs {

/// Where the rotation about the track axis comes from.
enum class RollSource {
  kAuto,       ///< attitude when the log has it for >= 3 fitted frames, else road plane
  kAttitude,   ///< gravity direction from the flight log's attitude
  kRoadPlane,  ///< road planes through the map points under the cameras
  kPositions,  ///< positions only (no correction; unobservable on a straight track)
};
const char* ToString(RollSource s);

/// The rig: where the antenna and the body axes are relative to the left camera.
struct RigGeometry {
  Eigen::Vector3d lever_arm_body_m = Eigen::Vector3d::Zero();  ///< antenna minus left camera, body FRD, m
  Eigen::Matrix3d R_body_cam = Eigen::Matrix3d::Identity();    ///< camera (OpenCV) axes in the body (FRD) frame
};

/// One frame as the inputs know it.
struct GeoFrame {
  int64_t frame = 0;  ///< frame id
  int64_t t_ns = 0;
  std::optional<Eigen::Isometry3d> T_slam_cam;  ///< placed by the trajectory (left camera-to-world)
  std::optional<Eigen::Vector3d> gnss_enu;      ///< antenna fix in the local ENU frame
  std::optional<Eigen::Matrix3d> R_ned_body;    ///< attitude from the flight log
};

struct GeoreferenceOptions {
  GnssFitOptions fit;
  RollSource roll_source = RollSource::kAuto;
  RoadPlaneOptions road;
};

/// Status of a frame in cameras.csv.
enum class CameraStatus { kVisual, kGnssOnly, kSkipped };
const char* ToString(CameraStatus s);

/// A frame's output pose in the local ENU frame.
struct GeoCamera {
  int64_t frame = 0, t_ns = 0;
  CameraStatus status = CameraStatus::kSkipped;
  Eigen::Vector3d p_enu = Eigen::Vector3d::Zero();  ///< left camera centre
  std::optional<Eigen::Matrix3d> R_ned_body;        ///< platform attitude (NED at the ENU origin)
};

/// Per-frame GNSS residual (fix minus fitted antenna), ENU.
struct GnssResidual {
  int64_t frame = 0, t_ns = 0;
  Eigen::Vector3d r_enu = Eigen::Vector3d::Zero();
  bool inlier = true;
};

struct GeoreferenceResult {
  GnssFit fit;                 ///< transform: SLAM world -> local ENU (roll included)
  RollSource roll_method = RollSource::kPositions;
  RollEstimate roll;
  int road_planes = 0;
  std::vector<GnssResidual> residuals;
  std::vector<GeoCamera> cameras;  ///< one per input frame, input order
};

/// Throws std::invalid_argument when fewer than 3 placed frames have a GNSS fix, or when
/// `options.roll_source` asks for attitude the log does not have.
GeoreferenceResult Georeference(const std::vector<GeoFrame>& frames, const std::vector<Eigen::Vector3d>& map_points_slam,
                                const RigGeometry& rig, const GeoreferenceOptions& options);

/// Local ENU <-> NED axes (the same matrix both ways).
Eigen::Matrix3d RotationEnuNed();

/// yaw (from north, clockwise), pitch, roll in degrees of an aerospace ZYX rotation body -> NED.
Eigen::Vector3d YawPitchRollDeg(const Eigen::Matrix3d& R_ned_body);

}  // namespace rs
