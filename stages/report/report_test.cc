// The report's data from stage files: orthophoto pieces (level under a budget, bounds, transparency),
// the map frame, damages and track in it, the residuals file, and errors on malformed input.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include <fstream>
#include <unistd.h>

#include "formats/geo/cameras_csv.h"
#include "formats/geo/geotiff.h"
#include "formats/geo/output_crs.h"
#include "formats/geojson/geojson.h"
#include "formats/input_error.h"
#include "stages/report/ortho_pieces.h"
#include "stages/report/report_data.h"
#include "tests/support/temp_dirs.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("rs_report_test_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  fs::create_directories(d);
  test::RemoveAtExit(d.parent_path());
  return d;
}

void WriteText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// A 700 x 300 orthophoto at 1 cm, grey road in columns [100, 600) and rows [50, 250), nodata elsewhere.
fs::path WriteOrtho(const fs::path& dir) {
  const fs::path path = dir / "ortho.tif";
  GeoTiffGeoreference g;
  g.x_min = 500000.0, g.y_max = 5000003.0, g.cell = 0.01, g.epsg = 32633;
  GeoTiffOptions opt;
  opt.tile_size = 256;
  opt.nodata = 0;
  GeoTiffWriter w(path, 700, 300, CV_8UC3, g, opt);
  for (int ty = 0; ty < w.tiles_down(); ++ty)
    for (int tx = 0; tx < w.tiles_across(); ++tx) {
      cv::Mat block(256, 256, CV_8UC3, cv::Scalar(0, 0, 0));
      for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
          const int gx = tx * 256 + x, gy = ty * 256 + y;
          if (gx >= 100 && gx < 600 && gy >= 50 && gy < 250) block.at<cv::Vec3b>(y, x) = {90, 100, 110};
        }
      const int w_px = std::min(256, 700 - tx * 256), h_px = std::min(256, 300 - ty * 256);
      w.WriteTile(tx, ty, block(cv::Rect(0, 0, w_px, h_px)).clone());
    }
  w.Finish();
  return path;
}

TEST(OrthoPieces, FullResolutionWhenTheRoadFitsTheBudget) {
  const fs::path dir = TempDir("ortho_full");
  const OrthoPieces p = WriteOrthoPieces(WriteOrtho(dir), dir / "report", {1'000'000, 256, 90});
  EXPECT_EQ(p.level, 0);
  EXPECT_DOUBLE_EQ(p.cell_x, 0.01);
  EXPECT_EQ(p.pixels, 500 * 200);
  // 3 x 2 pieces of 256 px cover 700 x 300; the second row [256, 300) holds no data (the road ends at 250).
  EXPECT_EQ(p.pieces.size(), 3u);
  double x_min = 1e18, x_max = -1e18, y_min = 1e18, y_max = -1e18;
  for (const OrthoPiece& piece : p.pieces) {
    ASSERT_TRUE(fs::exists(dir / "report" / piece.file)) << piece.file;
    x_min = std::min(x_min, piece.x_min), x_max = std::max(x_max, piece.x_max);
    y_min = std::min(y_min, piece.y_min), y_max = std::max(y_max, piece.y_max);
  }
  EXPECT_NEAR(x_min, 500000.0, 1e-9);
  EXPECT_NEAR(x_max, 500007.0, 1e-9);
  EXPECT_NEAR(y_max, 5000003.0, 1e-9);
  EXPECT_NEAR(y_min, 5000003.0 - 256 * 0.01, 1e-9);
  // Transparent where the orthophoto has no data, opaque on the road.
  const cv::Mat first = cv::imread((dir / "report" / p.pieces.front().file).string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(first.channels(), 4);
  EXPECT_EQ(first.at<cv::Vec4b>(10, 10)[3], 0);
  EXPECT_EQ(first.at<cv::Vec4b>(100, 150)[3], 255);
}

TEST(OrthoPieces, CoarserLevelUnderATightBudgetAndEmptyPiecesLeftOut) {
  const fs::path dir = TempDir("ortho_coarse");
  // 100 000 road pixels at 1 cm; 30 000 allowed: level 1 gives 25 000.
  const OrthoPieces p = WriteOrthoPieces(WriteOrtho(dir), dir / "report", {30'000, 128, 80});
  EXPECT_EQ(p.level, 1);
  EXPECT_NEAR(p.cell_x, 0.02, 1e-12);
  EXPECT_LE(p.pixels, 30'000 * 1.1);
  EXPECT_EQ(p.pieces.size(), 3u);  // 350 x 150 px in 128-px pieces: 3 x 2, the road in the first row
  // With 64-px pieces (6 x 3) the last column [320, 350) and the last row [128, 150) hold no data
  // (the road ends at 300 and 125) and are not written.
  const OrthoPieces fine = WriteOrthoPieces(dir / "ortho.tif", dir / "report64", {30'000, 64, 80});
  EXPECT_EQ(fine.pieces.size(), 10u);
  for (const OrthoPiece& piece : fine.pieces) {
    EXPECT_LE(piece.x_max, 500000.0 + 320 * 0.02 + 1e-9) << piece.file;
    EXPECT_GE(piece.y_min, 5000003.0 - 128 * 0.02 - 1e-9) << piece.file;
  }
}

TEST(MapFrame, RoundOriginAndLeafletOrderToTheMillimetre) {
  const MapFrame f = MapFrameAbout({456789.4, 5123456.7});
  EXPECT_DOUBLE_EQ(f.origin.x(), 456700.0);
  EXPECT_DOUBLE_EQ(f.origin.y(), 5123400.0);
  const nlohmann::json p = f.Point(456790.12345, 5123460.98765);
  EXPECT_DOUBLE_EQ(p[0].get<double>(), 60.988);  // y (north) first, as Leaflet's latlng
  EXPECT_DOUBLE_EQ(p[1].get<double>(), 90.123);
}

TEST(Damages, PolygonAndCrackOnTheMapWithCounts) {
  const fs::path dir = TempDir("damages");
  // On UTM zone 33's central meridian (15 E) easting is 500000 exactly.
  geojson::FeatureCollection fc;
  const double lat = 46.0, d = 2e-6;
  geojson::Polygon square{{{{15.0 - d, lat - d}, {15.0 + d, lat - d}, {15.0 + d, lat + d}, {15.0 - d, lat + d}}}};
  fc.features.push_back({square, {{"id", 1}, {"type", "pothole"}, {"severity", "high"}, {"area_m2", 0.1}}});
  geojson::LineString crack{{{15.0, lat}, {15.0, lat + 4 * d}}};
  fc.features.push_back({crack, {{"id", 2}, {"type", "crack"}, {"severity", "low"}, {"length_m", nullptr}}});
  geojson::WriteFeatureCollection(dir / "damage.geojson", fc);
  const OutputCrs crs("utm", {lat, 15.0, 0}, HeightReference::kEllipsoid);
  const Eigen::Vector3d centre = crs.Forward({lat, 15.0, 0});
  ASSERT_NEAR(centre.x(), 500000.0, 1e-6);
  const MapFrame frame = MapFrameAbout(centre.head<2>());
  const ReportDamages r = DamagesOnMap(dir / "damage.geojson", crs, 0.0, frame);
  ASSERT_EQ(r.damages.size(), 2u);
  const auto& pothole = r.damages[0];
  EXPECT_EQ(pothole["geometry"]["type"], "Polygon");
  EXPECT_EQ(pothole["geometry"]["coordinates"][0].size(), 5u);  // closed ring as written
  EXPECT_NEAR(pothole["centroid"][1].get<double>(), 500000.0 - frame.origin.x(), 1e-3);
  EXPECT_NEAR(pothole["centroid"][0].get<double>(), centre.y() - frame.origin.y(), 1e-3);
  EXPECT_EQ(pothole["properties"]["area_m2"], 0.1);
  const auto& line = r.damages[1];
  EXPECT_EQ(line["geometry"]["type"], "LineString");
  EXPECT_TRUE(line["properties"]["length_m"].is_null());
  // 8e-6 degrees of latitude is 0.89 m northwards.
  const double dy = line["geometry"]["coordinates"][1][0].get<double>() - line["geometry"]["coordinates"][0][0].get<double>();
  EXPECT_NEAR(dy, 0.8894, 0.002);
  EXPECT_EQ(r.counts["by_type"]["pothole"], 1);
  EXPECT_EQ(r.counts["by_severity"]["low"], 1);
}

constexpr const char* kCamerasHeader =
    "frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,yaw_deg,status\n";

TEST(Track, LengthDurationSkipsAndStride) {
  const fs::path dir = TempDir("track");
  std::string csv = kCamerasHeader;
  for (int i = 0; i < 5; ++i)
    csv += fmt::format("{},{},{},{},100,46,15,150,0,0,0,visual\n", i, 1'000'000'000LL + i * 100'000'000LL,
                       500000 + 3 * i, 5000000 + 4 * i);
  csv += "5,1500000000,,,,,,,,,,skipped\n";
  WriteText(dir / "cameras.csv", csv);
  const ReportTrack t = TrackOf(ReadCamerasCsv(dir / "cameras.csv"));
  EXPECT_EQ(t.positions.size(), 5u);
  EXPECT_EQ(t.skipped, 1);
  EXPECT_NEAR(t.length_m, 20.0, 1e-9);  // four steps of (3, 4)
  EXPECT_NEAR(t.duration_s, 0.4, 1e-12);
  const MapFrame f = MapFrameAbout(t.positions.front());
  const nlohmann::json pts = TrackPoints(t, 2, f);  // stride 3: cameras 0 and 3, then the last
  ASSERT_EQ(pts.size(), 3u);
  EXPECT_DOUBLE_EQ(pts[2][1].get<double>(), 12.0);
  EXPECT_DOUBLE_EQ(pts[2][0].get<double>(), 16.0);
}

TEST(Track, MalformedRowNamesFileLineAndColumn) {
  const fs::path dir = TempDir("track_bad");
  WriteText(dir / "cameras.csv", std::string(kCamerasHeader) + "0,1,500000,5000000,1,46,15,1,0,0,0,visual\n" +
                                     "1,2,5000x1,5000000,1,46,15,1,0,0,0,visual\n");
  try {
    ReadCamerasCsv(dir / "cameras.csv");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().column, 5);
    EXPECT_NE(std::string(e.what()).find("easting_m"), std::string::npos) << e.what();
  }
  WriteText(dir / "short.csv", std::string(kCamerasHeader) + "0,1,500000\n");
  EXPECT_THROW(ReadCamerasCsv(dir / "short.csv"), InputError);
  WriteText(dir / "foreign.csv", "t,x,y\n");
  EXPECT_THROW(ReadCamerasCsv(dir / "foreign.csv"), InputError);
}

TEST(Residuals, TimesFromTheFirstFixAndSigmaFromTheFit) {
  const fs::path dir = TempDir("residuals");
  WriteText(dir / "r.csv", "frame,t_ns,east_m,north_m,up_m,inlier\n3,2000000000,0.0100,-0.0200,0.0300,1\n"
                           "4,2500000000,0.5000,0.0000,0.0000,0\n");
  const nlohmann::json geo = {{"residuals", {{"robust_sigma_m", {{"east", 0.01}}}, {"definition", "d"}}}};
  const nlohmann::json r = ResidualsOf(dir / "r.csv", geo);
  ASSERT_EQ(r["fixes"].size(), 2u);
  EXPECT_DOUBLE_EQ(r["fixes"][1]["t_s"].get<double>(), 0.5);
  EXPECT_EQ(r["fixes"][1]["inlier"], false);
  EXPECT_DOUBLE_EQ(r["fixes"][0]["n"].get<double>(), -0.02);
  EXPECT_EQ(r["sigma_m"]["east"], 0.01);
  EXPECT_TRUE(ResidualsOf(dir / "absent.csv", geo).is_null());
  WriteText(dir / "bad.csv", "frame,t_ns,east_m,north_m,up_m,inlier\n3,2000000000,x,0,0,1\n");
  EXPECT_THROW(ResidualsOf(dir / "bad.csv", geo), InputError);
}

// What a survey without GNSS leaves (EuRoC indoors): no track, a damage map and surface that say why.
TEST(Summary, WithoutGeoreferenceOrSurface) {
  const fs::path dir = TempDir("summary");
  ReportSources src;
  for (const char* stage : {"ingest", "georeference", "damage_map", "surface"}) {
    src[stage] = dir / stage;
    fs::create_directories(src[stage]);
  }
  WriteText(src["ingest"] / "ingest.json", R"({"frames_listed": 95, "frames_usable": 95})");
  WriteText(src["damage_map"] / "damage_map.json", R"({"mapped": false, "reason": "not georeferenced"})");
  fs::create_directories(src["surface"] / "surface");
  WriteText(src["surface"] / "surface" / "surface.json", R"({"surface": false, "reason": "not georeferenced"})");
  const nlohmann::json geo = {{"georeferenced", false}, {"reason", "no GNSS"}};
  const nlohmann::json s = SurveySummary("indoor", src, ReportTrack{}, geo);
  EXPECT_FALSE(s["georeferenced"].get<bool>());
  EXPECT_TRUE(s["surface"].is_null());
  EXPECT_TRUE(s["date_utc"].is_null());
  EXPECT_EQ(s["frames"]["listed"], 95);
  EXPECT_EQ(s["frames"]["placed"], 0);
  EXPECT_EQ(s["gnss"]["fixes"], 0);
  EXPECT_FALSE(s["gnss"].contains("residual_rmse_m"));
  EXPECT_EQ(s["crs"]["epsg"], "");
}

}  // namespace
}  // namespace rs
