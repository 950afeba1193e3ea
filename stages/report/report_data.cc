#include "stages/report/report_data.h"

#include <fmt/format.h>

#include <GeographicLib/LocalCartesian.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <variant>

#include "formats/flight_log/track_csv.h"
#include "formats/geo/cameras_csv.h"
#include "formats/geo/output_crs.h"
#include "formats/geojson/geojson.h"
#include "formats/input_error.h"
#include "survey/atomic_file.h"
#include "survey/stage.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

double RoundTo(double v, double unit) { return std::round(v / unit) * unit; }

// A JSON file of a stage's folder, or null when the stage did not write it.
nlohmann::json JsonIfPresent(const fs::path& path) { return fs::exists(path) ? ReadJsonFile(path) : nlohmann::json(); }

const char* FixTypeName(int fix_type) {
  switch (fix_type) {
    case 0: return "no fix";
    case 2: return "2D";
    case 3: return "3D";
    case 4: return "DGPS";
    case 5: return "RTK float";
    case 6: return "RTK fixed";
    default: return "unknown";
  }
}

std::string IsoUtc(int64_t t_ns) {
  const std::time_t s = static_cast<std::time_t>(t_ns / 1'000'000'000);
  std::tm tm{};
  gmtime_r(&s, &tm);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour,
                     tm.tm_min, tm.tm_sec);
}

// Date and fix quality from the flight log as ingest normalised it (track.csv).
nlohmann::json GnssSummary(const fs::path& ingest_dir, const nlohmann::json& georeference, std::string* date_utc) {
  nlohmann::json gnss = {{"fixes", 0}, {"fix_types", nlohmann::json::object()}};
  const fs::path track_csv = ingest_dir / "track.csv";
  if (fs::exists(track_csv)) {
    const FlightTrack track = ReadTrackCsv(track_csv);
    gnss["fixes"] = track.fixes.size();
    std::map<std::string, int> types;
    for (const GnssFix& f : track.fixes) ++types[FixTypeName(f.fix_type)];
    gnss["fix_types"] = types;
    if (track.time_base == TimeBase::kUtc && !track.fixes.empty()) *date_utc = IsoUtc(track.fixes.front().t_ns);
  }
  const auto& res = georeference.value("residuals", nlohmann::json::object());
  if (res.contains("inliers") && res["inliers"].contains("rmse_m"))
    gnss["residual_rmse_m"] = {{"horizontal", res["inliers"]["rmse_m"]["horizontal"]},
                               {"vertical", res["inliers"]["rmse_m"]["up"]}};
  if (res.contains("robust_sigma_m")) gnss["robust_sigma_m"] = res["robust_sigma_m"];
  gnss["outliers"] = res.value("outliers", nlohmann::json::array()).size();
  return gnss;
}

// Frames the damage stage analysed: those selected less those it skipped (its run record).
int64_t FramesAnalysed(const ReportSources& src) {
  const auto damage = src.find("damage");
  if (damage == src.end() || !fs::exists(damage->second / kStageMarker)) return 0;
  const auto frames = ReadJsonFile(damage->second / kStageMarker).value("frames", nlohmann::json::object());
  return frames.value("total", int64_t{0}) - frames.value("skipped", int64_t{0});
}

// Every position of a GeoJSON geometry in the map frame, [y, x] order, rings and lines kept apart.
struct MapGeometry {
  nlohmann::json json;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
};

MapGeometry ToMap(const geojson::Geometry& g, const OutputCrs& crs, double height_m, const MapFrame& frame) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int n = 0;
  auto line = [&](const std::vector<geojson::Position>& positions, bool ring) {
    nlohmann::json out = nlohmann::json::array();
    for (size_t i = 0; i < positions.size(); ++i) {
      const Eigen::Vector3d p = crs.Forward({positions[i].lat_deg, positions[i].lon_deg, height_m});
      out.push_back(frame.Point(p.x(), p.y()));
      if (ring && i + 1 == positions.size() && positions.size() > 1) continue;  // the closing repeat
      sum += p.head<2>();
      ++n;
    }
    return out;
  };
  MapGeometry m;
  if (const auto* poly = std::get_if<geojson::Polygon>(&g)) {
    nlohmann::json rings = nlohmann::json::array();
    for (size_t r = 0; r < poly->rings.size(); ++r) {
      if (r > 0) {  // holes do not move the centre
        const Eigen::Vector2d keep = sum;
        const int keep_n = n;
        rings.push_back(line(poly->rings[r], true));
        sum = keep, n = keep_n;
      } else {
        rings.push_back(line(poly->rings[r], true));
      }
    }
    m.json = {{"type", "Polygon"}, {"coordinates", rings}};
  } else if (const auto* ls = std::get_if<geojson::LineString>(&g)) {
    m.json = {{"type", "LineString"}, {"coordinates", line(ls->positions, false)}};
  } else {
    throw std::invalid_argument("damage.geojson: only Polygon and LineString features are mapped");
  }
  if (n > 0) m.centre = sum / n;
  return m;
}

}  // namespace

nlohmann::json MapFrame::Point(double easting, double northing) const {
  return nlohmann::json::array({RoundTo(northing - origin.y(), 1e-3), RoundTo(easting - origin.x(), 1e-3)});
}

MapFrame MapFrameAbout(const Eigen::Vector2d& first) {
  MapFrame f;
  f.origin = Eigen::Vector2d(std::floor(first.x() / 100) * 100, std::floor(first.y() / 100) * 100);
  return f;
}

ReportDamages DamagesOnMap(const fs::path& geojson_path, const OutputCrs& crs, double height_m, const MapFrame& frame) {
  ReportDamages out;
  std::map<std::string, int> by_type, by_severity;
  for (const geojson::Feature& f : geojson::ReadFeatureCollection(geojson_path).features) {
    const MapGeometry g = ToMap(f.geometry, crs, height_m, frame);
    const std::string type = f.properties.value("type", std::string("other"));
    const std::string severity = f.properties.value("severity", std::string("none"));
    ++by_type[type];
    ++by_severity[severity];
    out.damages.push_back({{"id", f.properties.value("id", 0)},
                           {"type", type},
                           {"severity", severity},
                           {"geometry", g.json},
                           {"centroid", frame.Point(g.centre.x(), g.centre.y())},
                           {"thumbnail", nullptr},
                           {"properties", f.properties}});
  }
  out.counts = {{"by_type", by_type}, {"by_severity", by_severity}};
  return out;
}

ReportTrack TrackOf(const std::vector<CameraRow>& cameras) {
  ReportTrack t;
  int64_t t_first = 0, t_last = 0;
  for (const CameraRow& r : cameras) {
    if (!r.crs) {
      ++t.skipped;
      continue;
    }
    const Eigen::Vector2d p = r.crs->head<2>();
    if (t.positions.empty()) t_first = r.t_ns;
    else t.length_m += (p - t.positions.back()).norm();
    t_last = r.t_ns;
    t.positions.push_back(p);
  }
  t.duration_s = static_cast<double>(t_last - t_first) * 1e-9;
  return t;
}

nlohmann::json TrackPoints(const ReportTrack& track, int max_points, const MapFrame& frame) {
  nlohmann::json points = nlohmann::json::array();
  const size_t n = track.positions.size();
  if (n == 0) return points;
  const size_t stride = std::max<size_t>(1, (n + max_points - 1) / std::max(1, max_points));
  for (size_t i = 0; i < n; i += stride) points.push_back(frame.Point(track.positions[i].x(), track.positions[i].y()));
  if ((n - 1) % stride != 0) points.push_back(frame.Point(track.positions.back().x(), track.positions.back().y()));
  return points;
}

nlohmann::json ResidualsOf(const fs::path& csv, const nlohmann::json& georeference) {
  std::ifstream in(csv);
  if (!in) return nullptr;
  const std::string path = csv.string();
  std::string line;
  std::getline(in, line);  // header
  nlohmann::json fixes = nlohmann::json::array();
  int64_t t0 = 0;
  for (int64_t n = 2; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    long long frame = 0, t_ns = 0;
    double e = 0, no = 0, u = 0;
    int inlier = 0;
    if (std::sscanf(line.c_str(), "%lld,%lld,%lf,%lf,%lf,%d", &frame, &t_ns, &e, &no, &u, &inlier) != 6)
      throw InputError(InputLocation::Line(path, n), "expected frame,t_ns,east_m,north_m,up_m,inlier");
    if (fixes.empty()) t0 = t_ns;
    fixes.push_back({{"t_s", RoundTo(static_cast<double>(t_ns - t0) * 1e-9, 1e-3)},
                     {"frame", frame},
                     {"e", e},
                     {"n", no},
                     {"u", u},
                     {"inlier", inlier != 0}});
  }
  const auto& res = georeference.value("residuals", nlohmann::json::object());
  return {{"definition", res.value("definition", std::string("GNSS fix minus fitted antenna position, local ENU, m"))},
          {"sigma_m", res.value("robust_sigma_m", nlohmann::json())},
          {"fixes", fixes}};
}

nlohmann::json TrajectoryError(const std::vector<CameraRow>& cameras, const fs::path& reference_csv, int max_points) {
  std::ifstream in(reference_csv);
  const std::string path = reference_csv.string();
  if (!in) throw InputError(InputLocation::File(path), "cannot open the reference trajectory");
  std::string line;
  if (!std::getline(in, line) || line.rfind("t_ns,lat_deg,lon_deg,h_ellipsoid_m", 0) != 0)
    throw InputError(InputLocation::Line(path, 1), "expected header 't_ns,lat_deg,lon_deg,h_ellipsoid_m'");
  std::map<int64_t, Geodetic> reference;
  for (int64_t n = 2; std::getline(in, line); ++n) {
    if (line.empty() || line == "\r") continue;
    long long t_ns = 0;
    Geodetic g;
    char rest = 0;
    if (std::sscanf(line.c_str(), "%lld,%lf,%lf,%lf%c", &t_ns, &g.lat_deg, &g.lon_deg, &g.h_ellipsoid_m, &rest) < 4 ||
        (rest != 0 && rest != '\r') || !std::isfinite(g.lat_deg + g.lon_deg + g.h_ellipsoid_m))
      throw InputError(InputLocation::Line(path, n), "expected t_ns,lat_deg,lon_deg,h_ellipsoid_m");
    reference[t_ns] = g;
  }
  struct Difference {
    int64_t t_ns;
    double horizontal, vertical;
  };
  std::vector<Difference> diffs;
  for (const CameraRow& r : cameras) {
    const auto ref = reference.find(r.t_ns);
    if (!r.crs || ref == reference.end()) continue;
    // Ours in the reference point's local tangent plane: metres east, north, up of it.
    const GeographicLib::LocalCartesian local(ref->second.lat_deg, ref->second.lon_deg, ref->second.h_ellipsoid_m);
    double e = 0, no = 0, u = 0;
    local.Forward(r.lat_deg, r.lon_deg, r.h_ellipsoid_m, e, no, u);
    diffs.push_back({r.t_ns, std::hypot(e, no), u});
  }
  if (diffs.empty()) return nullptr;
  double hh = 0, vv = 0, h_max = 0, v_max = 0;
  for (const Difference& d : diffs) {
    hh += d.horizontal * d.horizontal, vv += d.vertical * d.vertical;
    h_max = std::max(h_max, d.horizontal), v_max = std::max(v_max, std::abs(d.vertical));
  }
  nlohmann::json frames = nlohmann::json::array();
  const size_t stride = std::max<size_t>(1, (diffs.size() + max_points - 1) / std::max(1, max_points));
  for (size_t i = 0; i < diffs.size(); i += stride)
    frames.push_back({{"t_s", RoundTo(static_cast<double>(diffs[i].t_ns - diffs.front().t_ns) * 1e-9, 1e-3)},
                      {"horizontal_m", RoundTo(diffs[i].horizontal, 1e-4)},
                      {"vertical_m", RoundTo(diffs[i].vertical, 1e-4)}});
  const double n = static_cast<double>(diffs.size());
  return {{"definition", "camera position minus the reference trajectory's at the same time: horizontal distance "
                         "and height difference (WGS84 ellipsoidal), m"},
          {"reference", reference_csv.filename().string()},
          {"cameras", diffs.size()},
          {"rmse_m", {{"horizontal", std::sqrt(hh / n)}, {"vertical", std::sqrt(vv / n)}}},
          {"max_m", {{"horizontal", h_max}, {"vertical", v_max}}},
          {"frames", frames}};
}

nlohmann::json SurveySummary(const std::string& name, const ReportSources& src, const ReportTrack& track,
                             const nlohmann::json& georeference) {
  const nlohmann::json ingest = ReadJsonFile(src.at("ingest") / "ingest.json");
  const nlohmann::json surface = JsonIfPresent(src.at("surface") / "surface" / "surface.json");
  std::string date;
  nlohmann::json gnss = GnssSummary(src.at("ingest"), georeference, &date);
  const auto crs = georeference.value("crs", nlohmann::json::object());
  nlohmann::json s = {
      {"name", name},
      {"date_utc", date.empty() ? nlohmann::json() : nlohmann::json(date)},
      {"georeferenced", georeference.value("georeferenced", false)},
      {"frames",
       {{"listed", ingest.value("frames_listed", 0)},
        {"usable", ingest.value("frames_usable", 0)},
        {"placed", track.positions.size()},
        {"analysed", FramesAnalysed(src)}}},
      {"length_m", RoundTo(track.length_m, 0.01)},
      {"duration_s", RoundTo(track.duration_s, 0.01)},
      {"crs",
       {{"spec", crs.value("spec", std::string())},
        {"epsg", crs.value("epsg", std::string())},
        {"heights", crs.value("heights", std::string())},
        {"units", "m"}}},
      {"gnss", gnss},
      {"surface", nullptr}};
  // A surface stage without georeferenced cameras writes surface.json with "surface": false and why.
  if (surface.is_object() && surface.value("surface", true) && surface.contains("grid"))
    s["surface"] = {{"area_m2", surface.value("area_m2", 0.0)},
                    {"cell_m", surface.at("grid").value("cell_m", 0.0)},
                    {"mean_sigma_m", surface.value("mean_sigma_m", nlohmann::json())}};
  return s;
}

nlohmann::json ProductLinks(const ReportSources& src) {
  struct Product {
    const char* stage;
    const char* file;  ///< in the stage's folder and, published, under the output folder
    const char* label;
  };
  static const Product kProducts[] = {
      {"damage_map", "damage.geojson", "Damage map (GeoJSON, WGS84)"},
      {"damage_map", "damage.csv", "Damage table (CSV, survey CRS)"},
      {"damage_map", "damage.qml", "QGIS style, damage polygons"},
      {"damage_map", "damage_cracks.qml", "QGIS style, cracks"},
      {"damage_map", "damage_map.json", "Damage map summary (JSON)"},
      {"surface", "surface/ortho.tif", "Orthophoto (GeoTIFF, full resolution)"},
      {"surface", "surface/dsm.tif", "Surface heights (GeoTIFF)"},
      {"surface", "surface/dsm_sigma.tif", "Height uncertainty, 1 σ (GeoTIFF)"},
      {"surface", "surface/dsm_count.tif", "Views per cell (GeoTIFF)"},
      {"surface", "surface/mesh.ply", "Road mesh (PLY)"},
      {"surface", "surface/mesh.obj", "Road mesh (OBJ)"},
      {"surface", "surface/mesh.json", "Road mesh CRS and offset (JSON)"},
      {"surface", "surface/surface.json", "Surface summary (JSON)"},
      {"georeference", "cameras.csv", "Cameras in the survey CRS (CSV)"},
      {"georeference", "trajectory.geojson", "Trajectory (GeoJSON, WGS84)"},
      {"georeference", "georeference.json", "Georeference fit (JSON)"},
      {"georeference", "georeference_residuals.csv", "GNSS residuals (CSV)"},
      {"georeference", "georeference_residuals.png", "GNSS residuals (plot)"},
      {"refine", "trajectory_refined.tum", "Refined trajectory (TUM)"},
      {"slam", "trajectory.tum", "SLAM trajectory (TUM)"},
      {"ingest", "ingest.json", "Ingest report (JSON)"},
  };
  nlohmann::json links = nlohmann::json::array();
  for (const Product& p : kProducts) {
    const auto dir = src.find(p.stage);
    if (dir == src.end() || !fs::exists(dir->second / p.file)) continue;
    links.push_back({{"label", p.label}, {"path", std::string("../") + p.file}, {"stage", p.stage}});
  }
  links.push_back({{"label", "Run manifest (JSON)"}, {"path", "../manifest.json"}, {"stage", "run"}});
  return links;
}

nlohmann::json MapExtent(const ReportTrack& track, const OrthoPieces* ortho, double margin, const MapFrame& frame) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Eigen::Vector2d lo(kInf, kInf), hi(-kInf, -kInf);
  for (const auto& p : track.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  if (ortho)
    for (const auto& piece : ortho->pieces) {
      lo = lo.cwiseMin(Eigen::Vector2d(piece.x_min, piece.y_min));
      hi = hi.cwiseMax(Eigen::Vector2d(piece.x_max, piece.y_max));
    }
  if (!(lo.x() <= hi.x())) return nullptr;
  return {frame.Point(lo.x() - margin, lo.y() - margin), frame.Point(hi.x() + margin, hi.y() + margin)};
}

}  // namespace rs
