#pragma once
// cameras.csv as the georeference stage writes it: one row per frame,
// `frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,yaw_deg,status`
// (docs/outputs.md). Rows of frames that were not placed (status `skipped`) have empty fields.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rs {

struct CameraRow {
  int64_t frame = 0;
  int64_t t_ns = 0;
  std::string status;  ///< "visual", "gnss-only" or "skipped"
  /// Easting, northing, height in the survey's CRS; absent for skipped frames.
  std::optional<Eigen::Vector3d> crs;
  double lat_deg = 0, lon_deg = 0, h_ellipsoid_m = 0;  ///< set with crs
  /// Roll, pitch, yaw of the body in NED, degrees; absent when the row has none.
  std::optional<Eigen::Vector3d> rpy_deg;
};

/// Reads every row. Throws InputError naming the file, line and column on a missing header, a
/// short row or a field that is not a number.
std::vector<CameraRow> ReadCamerasCsv(const std::filesystem::path& path);

}  // namespace rs
