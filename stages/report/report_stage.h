#pragma once
// Stage "report": one offline HTML page a road engineer reads (report/index.html): the survey's
// summary, a map of the orthophoto, trajectory and damage coloured by severity, a sortable damage
// table with thumbnails and every measurement, charts, and links to every product. Works from
// file:// with no network: Leaflet is copied in from Debian's libjs-leaflet, the data sits beside
// the page as JSON (and as scripts, since browsers do not let file:// pages fetch files).
// Docs: docs/stages/report.md.

#include <string>

#include "survey/stage.h"

namespace rs {

struct ReportOptions {
  int ortho_max_pixels = 8'000'000;  ///< orthophoto pixels with data shown on the map
  int ortho_piece_px = 1024;         ///< side of one orthophoto piece
  int ortho_quality = 80;            ///< WebP quality of the pieces
  int trajectory_max_points = 2000;  ///< points of the trajectory line
  int thumbnail_max_px = 480;        ///< larger thumbnails are scaled down
  /// CSV `t_ns,lat_deg,lon_deg,h_ellipsoid_m` the cameras are compared with (relative to the survey
  /// file); empty: no comparison.
  std::string reference_trajectory;
  std::string leaflet_dir = "/usr/share/javascript/leaflet";  ///< where libjs-leaflet installs Leaflet

  void Check() const;
  static const OptionTable<ReportOptions>& Table();
};

class ReportStage : public TypedStage<ReportStage, ReportOptions> {
 public:
  static StageInfo Info();
  void ValidateInputs(const SurveyFile& survey, const ReportOptions& o, ValidationDepth depth,
                      ProblemList& problems) const;
  std::string ExtraKeyOf(const SurveyFile& survey, const ReportOptions& o) const;
  void Run(StageContext& ctx, const ReportOptions& options) const;
};

}  // namespace rs
