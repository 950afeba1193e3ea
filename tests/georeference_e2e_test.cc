// End-to-end georeferencing of small simulated surveys: `roadsurvey simulate`, `run` and
// `eval georeference` exactly as a user runs them, scored against the simulator's truth.
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "tests/support/run_program.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

// Half-size images keep rendering and SLAM within the test budget; the geometry is the preset's.
// (Their SLAM rotations are ~0.4 deg worse: the centimetre test keeps the preset's full-size images.)
const char* kSmall = " --image_width 640 --image_height 360 --focal_px 500 --cx_px 320 --cy_px 180";

class GeoreferenceE2E : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("rs_georeference_e2e_" + std::to_string(::getpid()));
    fs::remove_all(root_);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // Simulates `preset` with `extra` options and runs the whole pipeline; the survey folder.
  static fs::path SimulateAndRun(const std::string& preset, const std::string& extra, const std::string& run_extra = "") {
    const fs::path dir = root_ / preset;
    auto r = RunProgram("simulate " + dir.string() + " --preset " + preset + " --progress quiet" + extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    r = RunProgram("run " + (dir / "survey.json").string() + " --progress quiet" + run_extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return dir;
  }
  static nlohmann::json Evaluate(const fs::path& dir, bool colmap) {
    const fs::path json = dir / "eval.json";
    const auto r = RunProgram("eval georeference " + (dir / "out").string() + " " + (dir / "truth").string() +
                              (colmap ? "" : " --no-colmap") + " --json " + json.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return ReadJson(json);
  }
  static fs::path root_;
};
fs::path GeoreferenceE2E::root_;

// RTK GNSS: camera centres within 3 cm RMSE, the fitted rotation (mean angle error) within 0.2 deg.
TEST_F(GeoreferenceE2E, RtkMeetsCentimetreTargets) {
  const fs::path dir = SimulateAndRun("rtk", " --num_frames 24");
  const auto ev = Evaluate(dir, /*colmap=*/true);
  const auto& ours = ev["ours"];
  EXPECT_EQ(ours["frames"].get<int>(), 24);
  const double h = ours["horizontal_rmse_m"], v = ours["vertical_rmse_m"];
  EXPECT_LT(std::hypot(h, v), 0.03) << ev.dump(1);
  for (const char* axis : {"heading", "pitch", "roll"}) {
    EXPECT_LT(std::abs(ours["mean_angle_error_deg"][axis].get<double>()), 0.2) << axis << ev.dump(1);
    EXPECT_LT(ours[std::string(axis) + "_deg"]["rms"].get<double>(), 0.3) << axis << ev.dump(1);
  }

  // The published files: one cameras.csv row per frame, a LineString, the report's stated method.
  const fs::path out = dir / "out";
  std::ifstream csv(out / "cameras.csv");
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header, "frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,yaw_deg,status");
  int rows = 0;
  while (std::getline(csv, line)) {
    ++rows;
    EXPECT_NE(line.find(",visual"), std::string::npos) << line;
  }
  EXPECT_EQ(rows, 24);
  const auto geo = ReadJson(out / "trajectory.geojson");
  EXPECT_EQ(geo["features"][0]["geometry"]["type"], "LineString");
  EXPECT_EQ(geo["features"][0]["geometry"]["coordinates"].size(), 24u);
  const auto report = ReadJson(out / "georeference.json");
  EXPECT_EQ(report["roll"]["method"], "attitude");
  EXPECT_EQ(report["crs"]["epsg"], "EPSG:32633");  // the simulator's origin (14.5 E) is in zone 33
  EXPECT_LT(report["residuals"]["inliers"]["rmse_m"]["horizontal"].get<double>(), 0.05);
  EXPECT_TRUE(fs::exists(out / "georeference_residuals.png"));
}

// Standard GNSS with a slowly varying bias: the fit follows the bias (nothing in that GNSS shows
// it), so our mean error equals the bias the simulator realised, to 0.1 m horizontally.
TEST_F(GeoreferenceE2E, BiasedGnssErrorIsTheRealisedBias) {
  const fs::path dir = SimulateAndRun("demo", std::string(kSmall) + " --num_frames 24");
  const auto ev = Evaluate(dir, /*colmap=*/false);
  EXPECT_LT(ev["ours_mean_error_minus_bias_horizontal_m"].get<double>(), 0.1) << ev.dump(1);
  const auto report = ReadJson(dir / "out" / "georeference.json");
  // The residuals are the white noise (0.4 m horizontal per axis, x1.5 vertical): within a factor 2.
  EXPECT_GT(report["residuals"]["robust_sigma_m"]["east"].get<double>(), 0.2);
  EXPECT_LT(report["residuals"]["robust_sigma_m"]["east"].get<double>(), 0.8);
}

// A straight road: roll within 0.2 deg from the attitude, 0.5 deg from the road plane alone,
// where the positions alone leave it loose.
TEST_F(GeoreferenceE2E, StraightRoadRollFromAttitudeAndRoadPlane) {
  const fs::path dir = SimulateAndRun("straight", std::string(kSmall) + " --num_frames 40");
  const fs::path survey = dir / "survey.json";
  const auto attitude = Evaluate(dir, /*colmap=*/false);
  EXPECT_LT(std::abs(attitude["ours"]["mean_angle_error_deg"]["roll"].get<double>()), 0.2) << attitude.dump(1);
  auto r = RunProgram("run " + survey.string() + " --progress quiet --georeference.roll_source road_plane");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(ReadJson(dir / "out" / "georeference.json")["roll"]["method"], "road_plane");
  const auto road = Evaluate(dir, /*colmap=*/false);
  EXPECT_LT(std::abs(road["ours"]["mean_angle_error_deg"]["roll"].get<double>()), 0.5) << road.dump(1);
}

// A crs PROJ does not know is reported by `validate` and stops `run` before any work, naming the code.
TEST_F(GeoreferenceE2E, UnknownCrsIsAnUpFrontError) {
  const fs::path dir = root_ / "bad_crs";
  auto r = RunProgram("simulate " + dir.string() + " --preset demo --progress quiet --num_frames 2" + kSmall);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path survey = dir / "survey.json";
  auto doc = ReadJson(survey);
  doc["crs"] = "EPSG:99999";
  std::ofstream(survey) << doc.dump(2);
  for (const char* command : {"validate ", "run "}) {
    r = RunProgram(command + survey.string());
    EXPECT_EQ(r.exit_code, 2) << command << r.output;
    EXPECT_NE(r.output.find("EPSG:99999"), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(dir / "out" / "manifest.json")) << "nothing ran";
}

}  // namespace
}  // namespace rs::test
