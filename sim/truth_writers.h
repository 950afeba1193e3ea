#pragma once
// Writers of the simulator's ground truth under <out>/truth/ (formats in
// docs/simulator.md).

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <GeographicLib/LocalCartesian.hpp>
#include <opencv2/core.hpp>

#include "sim/road_scene.h"
#include "sim/simulation_options.h"

namespace rs::sim {

/// TUM trajectory: one line "t_s tx ty tz qx qy qz qw" per pose (camera-to-world).
void WriteTum(const std::filesystem::path& path, const std::vector<int64_t>& t_ns,
              const std::vector<Eigen::Isometry3d>& T_world_cam);

/// The left camera centres as a reference trajectory for the report (report.reference_trajectory):
/// `t_ns,lat_deg,lon_deg,h_ellipsoid_m` per frame, WGS84 through the local ENU frame `enu`.
void WriteReferenceTrajectory(const std::filesystem::path& path, const std::vector<int64_t>& t_ns,
                              const std::vector<Eigen::Isometry3d>& T_world_cam,
                              const GeographicLib::LocalCartesian& enu);

/// KITTI-style disparity from depth: value = round(d * 256), d = fx_baseline_px_m / depth;
/// 0 where depth is 0 or d does not fit (d >= 256).
cv::Mat DisparityFromDepth(const cv::Mat& depth_m, double fx_baseline_px_m);

/// Damage list as RFC 7946 GeoJSON (WGS84, 8 decimals), one Feature per damage.
void WriteDamagesGeoJson(const std::filesystem::path& path, const RoadScene& scene,
                         const GeographicLib::LocalCartesian& enu);

/// The true road surface over s in [s0, s1] and the full corridor width as a
/// binary little-endian PLY triangle grid, vertices in local ENU metres (float).
void WriteRoadPly(const std::filesystem::path& path, const RoadScene& scene, double s0, double s1,
                  double lateral_half_width_m, double resolution_m);

/// georeference.json: the local ENU frame of every truth file and its WGS84 origin.
void WriteGeoreference(const std::filesystem::path& path, const SimulationOptions& o);

}  // namespace rs::sim
