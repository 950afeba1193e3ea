// End-to-end map products of a small simulated survey: `roadsurvey simulate`, `run`, `eval damage-map`
// and `eval surface` exactly as a user runs them, scored against the simulator's truth, and the
// published GeoJSON and GeoTIFFs read back by GDAL's own tools (Debian gdal-bin; skipped when absent).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <regex>

#include "tests/support/run_program.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

// Shoelace area of a lon/lat ring (positive: counter-clockwise).
double SignedArea(const nlohmann::json& ring) {
  double a = 0;
  for (size_t i = 0; i + 1 < ring.size(); ++i)
    a += ring[i][0].get<double>() * ring[i + 1][1].get<double>() - ring[i + 1][0].get<double>() * ring[i][1].get<double>();
  return a / 2;
}

// One feature per pothole the flight sees whole, placed within 10 cm; the measurements within
// their stated uncertainty.
void CheckAgainstTruth(const fs::path& dir, const ProgramResult& run) {
  const fs::path json = dir / "eval.json";
  const auto r = RunProgram("eval damage-map " + dir.string() + " --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto ev = ReadJson(json);
  const auto& pc = ev["potholes"]["counts"];
  ASSERT_GT(pc["seen"].get<int>(), 0) << "the flight must see some pothole whole: " << r.output;
  EXPECT_EQ(pc["duplicates"].get<int>(), 0) << r.output;
  EXPECT_GE(pc["recall"].get<double>(), 0.95) << r.output;
  EXPECT_GE(pc["precision"].get<double>(), 0.95) << r.output;
  EXPECT_LT(ev["potholes"]["summary"]["centroid_error_m"]["max_abs"].get<double>(), 0.10) << r.output;
  for (const auto& m : ev["potholes"]["matches"]) {
    if (!m["scored"].get<bool>() || m["floor_visible"] != true) continue;
    EXPECT_LT(std::abs(m["depth_error_mm"].get<double>()), 10.0) << m.dump();
    EXPECT_LT(std::abs(m["area_error_pct"].get<double>()), 10.0) << m.dump();
  }
  EXPECT_EQ(ev["cracks"]["counts"]["duplicates"].get<int>(), 0) << r.output;

  // The run's summary prints the map's counts by type and severity.
  EXPECT_NE(run.output.find(" potholes"), std::string::npos) << run.output;
}

// RFC 7946 as the map is written: WGS84 lon/lat near the survey, 8 decimals, counter-clockwise outer
// rings, no crs member; one CSV row and one thumbnail per feature.
void CheckRfc7946(const fs::path& dir) {
  const fs::path out = dir / "out";
  const std::string text = Slurp(out / "damage.geojson");
  const auto doc = nlohmann::json::parse(text);
  EXPECT_EQ(doc["type"], "FeatureCollection");
  EXPECT_FALSE(doc.contains("crs"));
  const auto truth = ReadJson(dir / "truth" / "georeference.json");
  const double lat0 = truth["origin"]["lat_deg"], lon0 = truth["origin"]["lon_deg"];
  const auto& features = doc["features"];
  ASSERT_GT(features.size(), 0u);
  for (const auto& f : features) {
    const auto& g = f["geometry"];
    std::vector<nlohmann::json> points;
    if (g["type"] == "Polygon") {
      ASSERT_EQ(g["coordinates"].size(), 1u);
      const auto& ring = g["coordinates"][0];
      ASSERT_GE(ring.size(), 4u);
      EXPECT_EQ(ring.front(), ring.back()) << "closed ring";
      EXPECT_GT(SignedArea(ring), 0) << "counter-clockwise outer ring, feature " << f["properties"]["id"];
      for (const auto& p : ring) points.push_back(p);
    } else {
      ASSERT_EQ(g["type"], "LineString");
      EXPECT_EQ(f["properties"]["type"], "crack");
      for (const auto& p : g["coordinates"]) points.push_back(p);
    }
    for (const auto& p : points) {  // within 200 m of the survey's origin (2e-3 deg at 45 deg N)
      EXPECT_NEAR(p[0].get<double>(), lon0, 3e-3);
      EXPECT_NEAR(p[1].get<double>(), lat0, 2e-3);
    }
    const fs::path thumb = out / f["properties"]["thumbnail"].get<std::string>();
    EXPECT_TRUE(fs::exists(thumb)) << thumb;
  }
  // Coordinates with 8 decimals (1.1 mm), no longer fractions.
  const std::regex geometry("\"coordinates\":\\[[^}]*"), long_fraction("[0-9]\\.[0-9]{9,}");
  int geometries = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), geometry); it != std::sregex_iterator(); ++it) {
    ++geometries;
    EXPECT_FALSE(std::regex_search(it->str(), long_fraction)) << it->str().substr(0, 200);
  }
  EXPECT_EQ(geometries, static_cast<int>(features.size()));
  std::ifstream csv(out / "damage.csv");
  std::string line;
  size_t rows = 0;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("id,easting_m,northing_m,height_m", 0), 0u) << line;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, features.size());
}

// GDAL reads the file as WGS84 with the right count and converts it to a GeoPackage.
void CheckWithGdal(const fs::path& dir) {
  if (std::system("command -v ogrinfo >/dev/null 2>&1 && command -v ogr2ogr >/dev/null 2>&1") != 0) {
    std::printf("note: ogrinfo/ogr2ogr not installed (Debian gdal-bin, installed by setup.sh): GDAL checks skipped\n");
    return;
  }
  const fs::path geojson = dir / "out" / "damage.geojson";
  const size_t features = ReadJson(geojson)["features"].size();
  const auto info = RunShell("ogrinfo -ro -al -so " + geojson.string());
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("Feature Count: " + std::to_string(features)), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("ID[\"EPSG\",4326]"), std::string::npos) << info.output;
  const fs::path gpkg = dir / "damage.gpkg";
  const auto conv = RunShell("ogr2ogr -f GPKG " + gpkg.string() + " " + geojson.string());
  ASSERT_EQ(conv.exit_code, 0) << conv.output;
  EXPECT_EQ(conv.output.find("Warning"), std::string::npos) << "every field converts as it is: " << conv.output;
  const auto back = RunShell("ogrinfo -ro -al -so " + gpkg.string());
  EXPECT_NE(back.output.find("Feature Count: " + std::to_string(features)), std::string::npos) << back.output;
}

// The road surface against the truth (a 1 cm truth mesh): the surface's own height error over the
// carriageway (the cameras' local placement error removed; measured 5.8 mm RMSE, median 3.3 mm on
// seed 1), its planimetric offset, how much of the imaged carriageway it fills, and the mesh within its
// stated decimation bound.
void CheckSurface(const fs::path& dir) {
  const fs::path json = dir / "surface_eval.json";
  const auto r = RunProgram("eval surface " + dir.string() + " --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto ev = ReadJson(json);
  EXPECT_LT(ev["relative"]["rmse_m"].get<double>(), 0.008) << r.output;
  EXPECT_LT(ev["relative"]["median_abs_m"].get<double>(), 0.005) << r.output;
  EXPECT_LT(std::abs(ev["relative"]["mean_m"].get<double>()), 0.003) << r.output;
  EXPECT_LT(ev["mesh"]["rmse_m"].get<double>(), ev["relative"]["rmse_m"].get<double>() + 0.001) << r.output;
  EXPECT_LT(ev["planimetric_error_m"].get<double>(), 0.04) << r.output;
  EXPECT_GT(ev["filled_fraction"].get<double>(), 0.99) << r.output;
  const auto mesh = ReadJson(dir / "out" / "surface" / "mesh.json");
  EXPECT_LE(mesh["measured_max_height_error_m"].get<double>(), mesh["max_height_error_m"].get<double>());
  EXPECT_LT(mesh["faces"].get<double>(), 0.5 * mesh["grid_faces"].get<double>()) << "decimated";
  EXPECT_EQ(mesh["crs"]["epsg"], "EPSG:32633");
}

// GDAL reads the DSM and the orthophoto in the survey's CRS, with overviews, over the flight.
void CheckSurfaceWithGdal(const fs::path& dir) {
  if (std::system("command -v gdalinfo >/dev/null 2>&1") != 0) {
    std::printf("note: gdalinfo not installed (Debian gdal-bin, installed by setup.sh): GeoTIFF checks skipped\n");
    return;
  }
  // The flight's camera centres (trajectory.geojson): a nadir flight lies inside the surface's extent.
  const auto track = ReadJson(dir / "out" / "trajectory.geojson");
  const auto& line = track["features"][0]["geometry"]["coordinates"];
  ASSERT_GT(line.size(), 2u);
  for (const char* name : {"dsm.tif", "ortho.tif"}) {
    const fs::path tif = dir / "out" / "surface" / name;
    const auto info = RunShell("gdalinfo -json " + tif.string());
    ASSERT_EQ(info.exit_code, 0) << info.output;
    const auto j = nlohmann::json::parse(info.output.substr(info.output.find('{')));
    EXPECT_NE(j["coordinateSystem"]["wkt"].get<std::string>().find("ID[\"EPSG\",32633]"), std::string::npos) << name;
    EXPECT_FALSE(j["bands"][0]["overviews"].empty()) << name;
    double lon0 = 1e9, lon1 = -1e9, lat0 = 1e9, lat1 = -1e9;
    for (const auto& p : j["wgs84Extent"]["coordinates"][0]) {
      lon0 = std::min(lon0, p[0].get<double>()), lon1 = std::max(lon1, p[0].get<double>());
      lat0 = std::min(lat0, p[1].get<double>()), lat1 = std::max(lat1, p[1].get<double>());
    }
    double tlon0 = 1e9, tlon1 = -1e9, tlat0 = 1e9, tlat1 = -1e9;
    for (const auto& p : line) {
      EXPECT_TRUE(p[0] >= lon0 && p[0] <= lon1 && p[1] >= lat0 && p[1] <= lat1) << name << " " << p.dump();
      tlon0 = std::min(tlon0, p[0].get<double>()), tlon1 = std::max(tlon1, p[0].get<double>());
      tlat0 = std::min(tlat0, p[1].get<double>()), tlat1 = std::max(tlat1, p[1].get<double>());
    }
    // ... and the extent is the flight's plus its footprint (about 8 m x 4.5 m at 6 m): within 10 m.
    EXPECT_LT(tlon0 - lon0, 1.5e-4) << name;  // 1.5e-4 deg of longitude ~ 11.6 m at 46 deg N
    EXPECT_LT(lon1 - tlon1, 1.5e-4) << name;
    EXPECT_LT(tlat0 - lat0, 0.9e-4) << name;  // 0.9e-4 deg of latitude ~ 10 m
    EXPECT_LT(lat1 - tlat1, 0.9e-4) << name;
  }
  const auto nodata = RunShell("gdalinfo " + (dir / "out" / "surface" / "dsm.tif").string());
  EXPECT_NE(nodata.output.find("NoData Value=-9999"), std::string::npos) << nodata.output;
}

// One rtk survey (a few minutes on two cores), simulated and run once for every check.
TEST(DamageMapE2E, RtkSurveyOnTheMap) {
  const fs::path root = fs::temp_directory_path() / ("rs_damage_map_e2e_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const fs::path dir = root / "rtk";
  auto r = RunProgram("simulate " + dir.string() + " --preset rtk --mesh_resolution_m 0.01 --progress quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const ProgramResult run = RunProgram("run " + (dir / "survey.json").string() + " --progress quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  {
    SCOPED_TRACE("against the simulator's truth");
    CheckAgainstTruth(dir, run);
  }
  {
    SCOPED_TRACE("RFC 7946");
    CheckRfc7946(dir);
  }
  {
    SCOPED_TRACE("GDAL");
    CheckWithGdal(dir);
  }
  {
    SCOPED_TRACE("surface against the simulator's truth");
    CheckSurface(dir);
  }
  {
    SCOPED_TRACE("surface GeoTIFFs through GDAL");
    CheckSurfaceWithGdal(dir);
  }
  if (!HasFailure()) fs::remove_all(root);
}

}  // namespace
}  // namespace rs::test
