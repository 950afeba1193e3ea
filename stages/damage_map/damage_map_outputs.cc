#include "stages/damage_map/damage_map_outputs.h"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <sstream>

#include "formats/checked_file.h"
#include "formats/geojson/geojson.h"
#include "formats/image_file.h"
#include "formats/stereo/image_io.h"

namespace rs {
namespace {

nlohmann::json Num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

geojson::Position LonLat(const GeographicLib::LocalCartesian& enu, const Eigen::Vector3d& p) {
  double lat, lon, h;
  enu.Reverse(p.x(), p.y(), p.z(), lat, lon, h);
  return {lon, lat, std::nullopt};
}

std::string CsvField(const nlohmann::json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) {
    std::string s = v.get<std::string>();
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
  }
  if (v.is_number_float()) return fmt::format("{:.6g}", v.get<double>());
  return v.dump();
}

// Field order of damage.csv after the coordinates (the GeoJSON properties, same names).
const std::vector<std::string>& CsvFields() {
  static const std::vector<std::string> f = {
      "type", "area_m2", "sigma_area_m2", "max_depth_m", "sigma_max_depth_m", "mean_depth_m", "sigma_mean_depth_m",
      "volume_m3", "sigma_volume_m3", "max_depth_seen_m", "max_depth_bound_m", "volume_upper_m3", "length_m",
      "sigma_length_m", "width_m", "sigma_width_m", "max_width_m", "max_diameter_m", "severity", "astm_d6433",
      "astm_d6433_rule", "fhwa_ltpp", "fhwa_ltpp_rule", "intervention", "intervention_rule", "chainage_m", "offset_m",
      "observations", "views_in_view", "detection_rate", "best_frame", "floor_visible", "outline_complete", "thumbnail", "basis"};
  return f;
}

}  // namespace

nlohmann::json DamageProperties(const MappedDamage& m, const std::vector<MapObservation>& obs) {
  // A text list ("12;13;14"): list-typed fields do not survive conversion to GeoPackage or Shapefile.
  std::string frames;
  for (int i : m.members) frames += (frames.empty() ? "" : ";") + std::to_string(obs[i].frame);
  const bool crack = m.type == "crack";
  return {{"id", m.id},
          {"type", m.type},
          {"area_m2", crack ? nullptr : Num(m.area_m2.value)},
          {"sigma_area_m2", crack ? nullptr : Num(m.area_m2.sigma)},
          {"max_depth_m", Num(m.max_depth_m.value)},
          {"sigma_max_depth_m", Num(m.max_depth_m.sigma)},
          {"mean_depth_m", Num(m.mean_depth_m.value)},
          {"sigma_mean_depth_m", Num(m.mean_depth_m.sigma)},
          {"volume_m3", Num(m.volume_m3.value)},
          {"sigma_volume_m3", Num(m.volume_m3.sigma)},
          {"max_depth_seen_m", Num(m.max_depth_seen_m)},
          {"max_depth_bound_m", Num(m.max_depth_bound_m)},
          {"volume_upper_m3", Num(m.volume_upper_m3)},
          {"length_m", Num(m.length_m.value)},
          {"sigma_length_m", Num(m.length_m.sigma)},
          {"width_m", Num(m.width_m.value)},
          {"sigma_width_m", Num(m.width_m.sigma)},
          {"max_width_m", Num(m.max_width_m)},
          {"max_diameter_m", Num(m.max_diameter_m)},
          {"severity", m.severity},
          {"astm_d6433", SeverityLevelName(m.astm.level)},
          {"astm_d6433_rule", m.astm.rule},
          {"fhwa_ltpp", SeverityLevelName(m.fhwa.level)},
          {"fhwa_ltpp_rule", m.fhwa.rule},
          {"intervention", m.intervention.needed},
          {"intervention_rule", m.intervention.rule},
          {"chainage_m", Num(m.chainage_m)},
          {"offset_m", Num(m.offset_m)},
          {"observations", m.members.size()},
          {"views_in_view", m.views_in_view},
          {"detection_rate", Num(m.detection_rate)},
          {"observation_frames", frames},
          {"best_frame", obs[m.best].frame},
          {"floor_visible", crack ? nullptr : nlohmann::json(m.floor_visible)},
          {"outline_complete", m.outline_complete},
          {"thumbnail", fmt::format("damage_thumbnails/{}.jpg", m.id)},
          {"basis", m.basis}};
}

void WriteDamageGeoJson(const std::filesystem::path& path, const std::vector<MappedDamage>& damages,
                        const std::vector<MapObservation>& obs, const GeographicLib::LocalCartesian& enu) {
  geojson::FeatureCollection fc;
  for (const MappedDamage& m : damages) {
    std::vector<geojson::Position> pts;
    for (const auto& p : m.geometry_enu) pts.push_back(LonLat(enu, p));
    geojson::Feature f;
    if (m.type == "crack")
      f.geometry = geojson::LineString{pts};
    else
      f.geometry = geojson::Polygon{{pts}};
    f.properties = DamageProperties(m, obs);
    f.id = std::to_string(m.id);
    fc.features.push_back(std::move(f));
  }
  std::ostringstream out;
  geojson::WriteFeatureCollection(out, fc);
  WriteFileChecked(path, out.view());
}

void WriteDamageCsv(const std::filesystem::path& path, const std::vector<MappedDamage>& damages,
                    const std::vector<MapObservation>& obs, const GeographicLib::LocalCartesian& enu,
                    const OutputCrs& crs) {
  std::ostringstream csv;
  csv << "id,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m";
  for (const auto& f : CsvFields()) csv << ',' << f;
  csv << '\n';
  for (const MappedDamage& m : damages) {
    Geodetic g;
    enu.Reverse(m.centroid_enu.x(), m.centroid_enu.y(), m.centroid_enu.z(), g.lat_deg, g.lon_deg, g.h_ellipsoid_m);
    const Eigen::Vector3d c = crs.Forward(g);
    csv << fmt::format("{},{:.4f},{:.4f},{:.4f},{:.9f},{:.9f},{:.4f}", m.id, c.x(), c.y(), c.z(), g.lat_deg,
                       g.lon_deg, g.h_ellipsoid_m);
    const nlohmann::json p = DamageProperties(m, obs);
    for (const auto& f : CsvFields()) csv << ',' << CsvField(p[f]);
    csv << '\n';
  }
  WriteFileChecked(path, csv.view());
}

void WriteQgisStyles(const std::filesystem::path& dir) {
  // Categorised by "severity" (none/low/medium/high), labelled by "id". QGIS applies a .qml
  // beside a layer of the same name when the layer is loaded.
  static const char* kLevels[][2] = {{"none", "128,128,128,255"}, {"low", "255,204,0,255"},
                                     {"medium", "255,128,0,255"}, {"high", "215,25,28,255"}};
  const auto style = [&](bool lines) {
    std::string categories, symbols;
    for (int i = 0; i < 4; ++i) {
      categories += fmt::format(R"(      <category render="true" symbol="{0}" value="{1}" label="{1}"/>
)",
                                i, kLevels[i][0]);
      const std::string layer =
          lines ? fmt::format(R"(<layer class="SimpleLine" enabled="1" pass="0" locked="0"><Option type="Map"><Option name="line_color" type="QString" value="{}"/><Option name="line_width" type="QString" value="0.8"/></Option></layer>)",
                              kLevels[i][1])
                : fmt::format(R"(<layer class="SimpleFill" enabled="1" pass="0" locked="0"><Option type="Map"><Option name="color" type="QString" value="{}"/><Option name="outline_color" type="QString" value="35,35,35,255"/><Option name="outline_width" type="QString" value="0.3"/><Option name="style" type="QString" value="solid"/></Option></layer>)",
                              kLevels[i][1]);
      symbols += fmt::format(R"(      <symbol type="{}" name="{}" alpha="{}" clip_to_extent="1" force_rhr="0">{}</symbol>
)",
                             lines ? "line" : "fill", i, lines ? "1" : "0.7", layer);
    }
    return fmt::format(R"(<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>
<qgis version="3.22.0" styleCategories="Symbology|Labeling">
  <renderer-v2 type="categorizedSymbol" attr="severity" enableorderby="0" forceraster="0" symbollevels="0">
    <categories>
{}    </categories>
    <symbols>
{}    </symbols>
  </renderer-v2>
  <labeling type="simple">
    <settings calloutType="simple">
      <text-style fieldName="id" isExpression="0" fontSize="9" textColor="0,0,0,255" fontWeight="75"/>
      <text-buffer bufferDraw="1" bufferSize="1" bufferColor="255,255,255,255"/>
      <placement placement="{}"/>
    </settings>
  </labeling>
</qgis>
)",
                       categories, symbols, lines ? 2 : 0);
  };
  WriteFileChecked(dir / "damage.qml", style(false));
  WriteFileChecked(dir / "damage_cracks.qml", style(true));
}

void WriteThumbnail(const std::filesystem::path& path, const std::filesystem::path& left_image,
                    const MapObservation& best) {
  const cv::Mat image = LoadColor8(left_image);
  std::vector<cv::Point> outline;
  for (const auto& p : best.detection.outline_px) outline.emplace_back(p.x(), p.y());
  cv::Rect box = cv::boundingRect(outline);
  const int pad = std::max(16, std::max(box.width, box.height) / 2);
  box = cv::Rect(box.x - pad, box.y - pad, box.width + 2 * pad, box.height + 2 * pad) & cv::Rect(0, 0, image.cols, image.rows);
  cv::Mat crop = image(box).clone();
  for (auto& p : outline) p -= box.tl();
  const bool crack = best.detection.type == "crack";
  const cv::Scalar colour = crack ? cv::Scalar(0, 255, 255) : cv::Scalar(0, 0, 255);
  cv::polylines(crop, std::vector<std::vector<cv::Point>>{outline}, !crack, colour, std::max(1, crop.cols / 200),
                cv::LINE_AA);
  WriteImageFile(path, crop);
}

}  // namespace rs
