// The survey files in examples/ on the real public data (docs: examples/README.md): each validates and runs
// to exit 0 with its published outputs. Runs the built program as a user would, writing to a temporary
// folder through --output (never into the source tree). Skips with a message when the data folder is absent.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "tests/support/run_program.h"
#include "tests/support/temp_dirs.h"
#include "tests/support/test_data.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

fs::path ExamplesDir() { return fs::path(ROADSURVEY_SOURCE_DIR) / "examples"; }

// A fresh folder per test program, removed when it exits.
fs::path TempRoot() {
  static const fs::path root = [] {
    const fs::path r = fs::temp_directory_path() / ("rs_examples_" + std::to_string(::getpid()));
    fs::remove_all(r);
    fs::create_directories(r);
    RemoveAtExit(r);
    return r;
  }();
  return root;
}

std::string Quote(const fs::path& p) { return "'" + p.string() + "'"; }

// Data lines of a TUM trajectory (comments and blank lines left out).
int TumPoses(const fs::path& p) {
  std::ifstream in(p);
  int n = 0;
  for (std::string line; std::getline(in, line);) n += !line.empty() && line[0] != '#';
  return n;
}

// Frame folders under out/<stage> that hold `file`.
int FramesWith(const fs::path& out, const std::string& stage, const std::string& file) {
  int n = 0;
  if (!fs::is_directory(out / stage)) return 0;
  for (const auto& e : fs::directory_iterator(out / stage)) n += fs::exists(e.path() / file);
  return n;
}

int StatusCount(const nlohmann::json& manifest, const std::string& status) {
  int n = 0;
  for (const auto& [name, stage] : manifest["stages"].items()) n += stage["status"] == status;
  return n;
}

// validate, then run into a temporary output folder; returns that folder.
fs::path ValidateAndRun(const fs::path& survey, const std::string& name) {
  const auto v = RunProgram("validate " + Quote(survey));
  EXPECT_EQ(v.exit_code, 0) << v.output;
  EXPECT_NE(v.output.find(" 0 error(s)"), std::string::npos) << v.output;
  const fs::path out = TempRoot() / name;
  const auto r = RunProgram("run " + Quote(survey) + " --output " + Quote(out) + " --progress quiet");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Outputs in " + out.string()), std::string::npos) << r.output;
  std::cout << r.output;  // the figures examples/README.md quotes
  return out;
}

// Every published output of a run over `frames` frames, and every stage computed.
void ExpectPublished(const fs::path& out, int frames) {
  ASSERT_TRUE(fs::exists(out / "manifest.json"));
  const auto manifest = ReadJson(out / "manifest.json");
  EXPECT_EQ(StatusCount(manifest, "computed"), static_cast<int>(manifest["stages"].size())) << manifest.dump(1);
  EXPECT_TRUE(fs::exists(out / "ingest.json"));
  EXPECT_EQ(FramesWith(out, "disparity", "disparity.png"), frames) << "a disparity for every frame";
  EXPECT_EQ(FramesWith(out, "disparity", "road_model.json"), frames);
  EXPECT_EQ(FramesWith(out, "damage", "detections.json"), frames) << "detections for every frame";
  EXPECT_EQ(TumPoses(out / "trajectory.tum"), frames) << "a pose for every frame";
}

TEST(Examples, ValidateAll) {
  RS_REQUIRE_DATA(DataRoot());
  std::vector<fs::path> surveys;
  for (const auto& e : fs::directory_iterator(ExamplesDir()))
    if (e.path().extension() == ".json") surveys.push_back(e.path());
  std::sort(surveys.begin(), surveys.end());
  ASSERT_EQ(surveys.size(), 3u) << "examples/*.json: KITTI odometry, KITTI raw + OXTS, EuRoC";
  std::string args;
  for (const auto& s : surveys) args += " " + Quote(s);
  const auto r = RunProgram("validate" + args);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("3 survey file(s), 0 with errors"), std::string::npos) << r.output;
}

// Without the data folder the path variable fails at the survey file's line, exit 2 (bad input).
TEST(Examples, MissingDataFolderIsALocatedInputError) {
  const char* saved = std::getenv("ROADSURVEY_DATA");
  const std::string restore = saved ? saved : "";
  ::setenv("ROADSURVEY_DATA", (TempRoot() / "no_such_folder").c_str(), 1);
  const auto r = RunProgram("validate " + Quote(ExamplesDir() / "kitti_odometry_06.json"));
  if (saved)
    ::setenv("ROADSURVEY_DATA", restore.c_str(), 1);
  else
    ::unsetenv("ROADSURVEY_DATA");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("kitti_odometry_06.json:6:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not a folder"), std::string::npos) << r.output;
}

TEST(Examples, KittiOdometry06) {
  RS_REQUIRE_DATA(DataRoot() / "kitti_vo_clips" / "KITTI_sequence_1");
  const fs::path out = ValidateAndRun(ExamplesDir() / "kitti_odometry_06.json", "kitti_odometry_06");
  ExpectPublished(out, 51);
  const auto ingest = ReadJson(out / "ingest.json");
  EXPECT_NE(ingest.dump().find("kitti-odometry"), std::string::npos) << ingest.dump(1);
}

TEST(Examples, KittiRaw0023Oxts) {
  RS_REQUIRE_DATA(DataRoot() / "kitti_raw_tiny");
  const fs::path out = ValidateAndRun(ExamplesDir() / "kitti_raw_0023_oxts.json", "kitti_raw_0023_oxts");
  ExpectPublished(out, 7);
  const std::string ingest = ReadJson(out / "ingest.json").dump();
  EXPECT_NE(ingest.find("kitti-oxts"), std::string::npos) << "the OXTS records are the flight log: " << ingest;
  // Georeferenced on the OXTS RTK positions: the residuals are the OXTS error (RTK, a few cm) plus
  // camera-to-log timing jitter (~5 ms at ~9 m/s = 5 cm), within 0.15 m RMS horizontally, 0.10 m vertically.
  const auto geo = ReadJson(out / "georeference.json");
  EXPECT_TRUE(geo["georeferenced"].get<bool>()) << geo.dump(1);
  EXPECT_EQ(geo["roll"]["method"], "attitude");
  EXPECT_GE(geo["residuals"]["inliers"]["frames"].get<int>(), 6);
  EXPECT_LT(geo["residuals"]["inliers"]["rmse_m"]["horizontal"].get<double>(), 0.15) << geo["residuals"].dump(1);
  EXPECT_LT(geo["residuals"]["inliers"]["rmse_m"]["up"].get<double>(), 0.10) << geo["residuals"].dump(1);
  EXPECT_EQ(geo["frames"]["visual"].get<int>(), 7);
}

TEST(Examples, EurocV101Micro) {
  RS_REQUIRE_DATA(DataRoot() / "euroc_v101_micro");
  const fs::path out = ValidateAndRun(ExamplesDir() / "euroc_v101_micro.json", "euroc_v101_micro");
  const auto manifest = ReadJson(out / "manifest.json");
  const int frames = FramesWith(out, "disparity", "disparity.png");
  EXPECT_GE(frames, 90) << "the micro extract holds 95 pairs";
  ExpectPublished(out, frames);
  // No GNSS indoors: the cameras are not on a map, and the report says so instead of drawing one.
  const auto report = ReadJson(out / "report" / "data" / "report.json");
  EXPECT_FALSE(report["survey"]["georeferenced"].get<bool>());
  EXPECT_TRUE(report["map"].is_null());
  EXPECT_EQ(report["survey"]["frames"]["placed"], 0);
}

// The Fan 2021 pairs follow no supported layout: stage.sh links them into the plain layout first.
TEST(Examples, Fan2021Model3) {
  RS_REQUIRE_DATA(DataRoot() / "pothole_recon_fan2021" / "model3");
  const fs::path staged = TempRoot() / "fan2021_model3";
  const int rc = std::system(("ROADSURVEY_DATA=" + Quote(DataRoot()) + " sh " +
                              Quote(ExamplesDir() / "fan2021_model3" / "stage.sh") + " " + Quote(staged))
                                 .c_str());
  ASSERT_EQ(rc, 0);
  const fs::path out = ValidateAndRun(staged / "survey.json", "fan2021_model3_out");
  ExpectPublished(out, 5);
  // The road model is reliable on every pair (GPT-SGM, no fallback), and each pair's pothole is found as a
  // measured depression (typed "other", not graded: see examples/README.md).
  for (const auto& e : fs::directory_iterator(out / "disparity")) {
    const auto road = ReadJson(e.path() / "road_model.json");
    EXPECT_FALSE(road["fell_back"].get<bool>()) << e.path() << ": " << road.dump();
  }
  for (const auto& e : fs::directory_iterator(out / "damage")) {
    if (!fs::exists(e.path() / "detections.json")) continue;
    const auto detections = ReadJson(e.path() / "detections.json");
    int depressions = 0;
    for (const auto& d : detections["detections"])
      depressions += d["max_depth_m"].is_number() && d["max_depth_m"].get<double>() > 0.005;
    EXPECT_GE(depressions, 1) << e.path() << ": " << detections.dump().substr(0, 2000);
  }
}

// Flight logs without frames to pair with: examples/README.md shows them with `roadsurvey log`.
TEST(Examples, FlightLogsWithoutFrames) {
  RS_REQUIRE_DATA(DataRoot() / "dji_srt");
  for (const char* log : {"dji_srt/samples/p4_rtk.SRT", "px4_ulog/test/sample_log_small.ulg",
                          "ardupilot_dataflash/pxf/copter/5-12-2014/218.BIN"}) {
    const auto r = RunProgram("log " + Quote(DataRoot() / log));
    EXPECT_EQ(r.exit_code, 0) << log << "\n" << r.output;
    EXPECT_NE(r.output.find("fixes"), std::string::npos) << r.output;
    std::cout << "$ roadsurvey log " << log << "\n" << r.output;
  }
}

}  // namespace
}  // namespace rs::test
