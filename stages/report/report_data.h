#pragma once
// What the report shows, gathered from the finished stages' outputs into one JSON document
// (window.ROADSURVEY_REPORT in report/data/report.js; docs/stages/report.md). Map coordinates are
// the survey's CRS minus a round origin, in Leaflet's [y, x] order, rounded to the millimetre.
// Nothing here measures anything: every figure comes from a stage's file.

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "formats/geo/cameras_csv.h"
#include "stages/report/ortho_pieces.h"

namespace rs {

class OutputCrs;

/// The run folders (under work/) of the stages the report reads, by stage name.
using ReportSources = std::map<std::string, std::filesystem::path>;

/// The map's local frame: CRS coordinates minus `origin`, [y, x] order for Leaflet's simple CRS.
struct MapFrame {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  ///< easting, northing subtracted
  nlohmann::json Point(double easting, double northing) const;
};

/// A round origin (multiple of 100 CRS units) below the first position.
MapFrame MapFrameAbout(const Eigen::Vector2d& first);

/// damage.geojson's features in the map frame: id, type, severity, geometry ([y, x]), centroid,
/// thumbnail (when copied), every property; and counts by type and severity.
struct ReportDamages {
  nlohmann::json damages = nlohmann::json::array();
  nlohmann::json counts;
};
ReportDamages DamagesOnMap(const std::filesystem::path& geojson, const OutputCrs& crs, double height_m,
                           const MapFrame& frame);

/// The placed cameras' ground track (cameras.csv's rows), its horizontal length and duration; `skipped`
/// counts cameras without a position.
struct ReportTrack {
  std::vector<Eigen::Vector2d> positions;  ///< easting, northing in flight order
  double length_m = 0, duration_s = 0;
  int skipped = 0;
};
ReportTrack TrackOf(const std::vector<CameraRow>& cameras);

/// At most `max_points` of the track in the map frame (evenly strided, first and last kept).
nlohmann::json TrackPoints(const ReportTrack& track, int max_points, const MapFrame& frame);

/// georeference_residuals.csv with times from the first fix, or null when the file is absent.
nlohmann::json ResidualsOf(const std::filesystem::path& csv, const nlohmann::json& georeference);

/// A reference trajectory: `t_ns,lat_deg,lon_deg,h_ellipsoid_m`, the left camera's WGS84 position at
/// each frame time, from a source independent of the survey (a post-processed GNSS solution, or the
/// simulator's truth). Returns every camera (cameras.csv's rows) with a reference at its t_ns: the
/// horizontal and vertical difference (ours minus reference, metres), at most `max_points` of them,
/// with the RMSE and maximum over all. Throws InputError naming the file and line on a malformed row.
nlohmann::json TrajectoryError(const std::vector<CameraRow>& cameras, const std::filesystem::path& reference_csv,
                               int max_points);

/// Date, frames, length, CRS, GNSS quality and surface figures for the summary panel.
nlohmann::json SurveySummary(const std::string& name, const ReportSources& src, const ReportTrack& track,
                             const nlohmann::json& georeference);

/// The product files that exist, as links relative to the report folder.
nlohmann::json ProductLinks(const ReportSources& src);

/// Map extent ([y, x] corners) over the track and the orthophoto, `margin` added on every side;
/// null when there is neither.
nlohmann::json MapExtent(const ReportTrack& track, const OrthoPieces* ortho, double margin, const MapFrame& frame);

}  // namespace rs
