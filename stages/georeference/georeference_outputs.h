#pragma once
// The stage's published files from a GeoreferenceResult: cameras.csv, trajectory.geojson and
// the report georeference.json (docs/outputs.md).

#include <filesystem>

#include <GeographicLib/LocalCartesian.hpp>
#include <nlohmann/json.hpp>

#include "formats/geo/output_crs.h"
#include "stages/georeference/georeference.h"

namespace rs {

/// georeference_residuals.csv: `frame,t_ns,east_m,north_m,up_m,inlier`, one row per GNSS fix fitted
/// (GNSS fix minus fitted antenna position, local ENU).
void WriteGnssResidualCsv(const std::filesystem::path& path, const std::vector<GnssResidual>& residuals);

/// The frame the fit works in and the CRS the outputs are written in.
struct GeoFrames {
  GeographicLib::LocalCartesian enu;  ///< local ENU of the fit (tangent at `origin`)
  Geodetic origin;
  const OutputCrs* crs = nullptr;
};

/// cameras.csv: frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,
/// yaw_deg,status; skipped frames and unknown attitudes leave their fields empty.
void WriteCamerasCsv(const std::filesystem::path& path, const GeoreferenceResult& result, const GeoFrames& frames);

/// trajectory.geojson: one RFC 7946 LineString (WGS84, ellipsoidal heights) through the placed cameras.
void WriteTrajectoryGeoJson(const std::filesystem::path& path, const GeoreferenceResult& result, const GeoFrames& frames);

/// georeference.json's body: transform, CRS, origin, residual statistics, roll method, scale.
nlohmann::json GeoreferenceReport(const GeoreferenceResult& result, const GeoFrames& frames, bool estimate_scale);

}  // namespace rs
