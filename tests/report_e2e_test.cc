// The report of the README demo as a user makes it (`roadsurvey simulate`, `run`): its figures are the
// products' (damages, track) and agree with the evaluation against the simulator's truth; a missing
// map library or a bad reference trajectory fails the report alone, naming the file; a report option
// re-runs the report only. The page itself is checked in a browser by tests/report/.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "tests/support/run_program.h"
#include "tests/support/temp_dirs.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

class ReportE2E : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("rs_report_e2e_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    RemoveAtExit(root_);
    fs::create_directories(root_);
    const auto sim = RunProgram("simulate " + Demo().string() + " --progress quiet");
    ASSERT_EQ(sim.exit_code, 0) << sim.output;
    const auto run = Run("");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    first_output_ = run.output;
  }
  static fs::path Demo() { return root_ / "demo"; }
  static fs::path Out() { return Demo() / "out"; }
  // The mesh is left out: the report links it when present and does not read it.
  static ProgramResult Run(const std::string& extra) {
    return RunProgram("run " + (Demo() / "survey.json").string() + " --progress quiet --surface.mesh false " + extra);
  }
  static std::string StatusOf(const std::string& stage) {
    return ReadJson(Out() / "manifest.json")["stages"][stage]["status"].get<std::string>();
  }
  static fs::path root_;
  static std::string first_output_;
};
fs::path ReportE2E::root_;
std::string ReportE2E::first_output_;

TEST_F(ReportE2E, DamagesAndCountsAreTheMapsFeatures) {
  const auto report = ReadJson(Out() / "report" / "data" / "report.json");
  const auto geojson = ReadJson(Out() / "damage.geojson");
  ASSERT_EQ(report["damages"].size(), geojson["features"].size());
  std::map<std::string, int> by_type;
  for (size_t i = 0; i < report["damages"].size(); ++i) {
    const auto& d = report["damages"][i];
    const auto& p = geojson["features"][i]["properties"];
    EXPECT_EQ(d["id"], p["id"]);
    EXPECT_EQ(d["type"], p["type"]);
    EXPECT_EQ(d["properties"], p) << "every property as the damage map states it";
    EXPECT_EQ(d["geometry"]["type"], geojson["features"][i]["geometry"]["type"]);
    ++by_type[d["type"].get<std::string>()];
    if (!d["thumbnail"].is_null()) {
      EXPECT_TRUE(fs::exists(Out() / "report" / d["thumbnail"].get<std::string>()));
    }
  }
  for (const auto& [type, n] : by_type) EXPECT_EQ(report["counts"]["by_type"][type], n) << type;
  // The published JSON and the script the page loads hold the same data.
  const std::string js = Slurp(Out() / "report" / "data" / "report.js");
  EXPECT_EQ(js, "window.ROADSURVEY_REPORT = " + report.dump() + ";\n");
  EXPECT_NE(first_output_.find("report/index.html"), std::string::npos) << first_output_;
}

TEST_F(ReportE2E, MapHoldsTheTrackDamagesAndOrthophoto) {
  const auto report = ReadJson(Out() / "report" / "data" / "report.json");
  const auto& map = report["map"];
  ASSERT_TRUE(map.is_object());
  const auto& extent = map["extent"];  // [[y_min, x_min], [y_max, x_max]]
  auto inside = [&](const nlohmann::json& p) {
    return p[0] >= extent[0][0] && p[0] <= extent[1][0] && p[1] >= extent[0][1] && p[1] <= extent[1][1];
  };
  ASSERT_EQ(map["trajectory"].size(), 48u);  // the demo's 48 cameras, fewer than trajectory_max_points
  for (const auto& p : map["trajectory"]) EXPECT_TRUE(inside(p)) << p;
  ASSERT_GT(map["ortho"]["pieces"].size(), 0u);
  for (const auto& piece : map["ortho"]["pieces"]) {
    EXPECT_TRUE(fs::exists(Out() / "report" / piece["file"].get<std::string>()));
    EXPECT_TRUE(inside(piece["bounds"][0]) && inside(piece["bounds"][1])) << piece;
  }
  // The demo's 137 m² of road at 1 cm fit the default budget: full resolution.
  EXPECT_DOUBLE_EQ(map["ortho"]["cell_m"].get<double>(), 0.01);
  // Every pothole lies on the orthophoto's pieces (the imaged road).
  for (const auto& d : report["damages"]) {
    if (d["type"] != "pothole") continue;
    bool on_ortho = false;
    for (const auto& piece : map["ortho"]["pieces"]) {
      const auto& b = piece["bounds"];
      on_ortho |= d["centroid"][0] >= b[0][0] && d["centroid"][0] <= b[1][0] && d["centroid"][1] >= b[0][1] &&
                  d["centroid"][1] <= b[1][1];
    }
    EXPECT_TRUE(on_ortho) << "pothole " << d["id"];
  }
}

// The track's length and the cameras' error against the simulator's truth, as the evaluation states them.
TEST_F(ReportE2E, TrackLengthAndTrajectoryErrorAgreeWithTruth) {
  const auto report = ReadJson(Out() / "report" / "data" / "report.json");
  double truth_length = 0;
  {
    std::ifstream in(Demo() / "truth" / "trajectory.tum");
    std::string line;
    bool first = true;
    double px = 0, py = 0;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream f(line);
      double t, x, y;
      f >> t >> x >> y;
      if (!first) truth_length += std::hypot(x - px, y - py);
      px = x, py = y, first = false;
    }
  }
  // Track length: the cameras' placement error is about constant over 4 s (a common GNSS bias).
  EXPECT_NEAR(report["survey"]["length_m"].get<double>(), truth_length, 0.02 * truth_length);
  EXPECT_EQ(report["survey"]["frames"]["placed"], 48);

  const fs::path json = root_ / "eval_georeference.json";
  const auto ev = RunProgram("eval georeference " + Out().string() + " " + (Demo() / "truth").string() +
                             " --no-colmap --json " + json.string());
  ASSERT_EQ(ev.exit_code, 0) << ev.output;
  const auto ours = ReadJson(json)["ours"];
  const auto& te = report["trajectory_error"];
  ASSERT_TRUE(te.is_object()) << "the simulator's survey.json names its truth as the reference";
  EXPECT_EQ(te["cameras"], ours["frames"]);
  EXPECT_NEAR(te["rmse_m"]["horizontal"].get<double>(), ours["horizontal_rmse_m"].get<double>(), 1e-3);
  EXPECT_NEAR(te["rmse_m"]["vertical"].get<double>(), ours["vertical_rmse_m"].get<double>(), 1e-3);
}

TEST_F(ReportE2E, ReportOptionRerunsTheReportOnly) {
  const auto r = Run("--report.ortho_quality 60");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(StatusOf("report"), "computed");
  for (const char* stage : {"ingest", "disparity", "damage", "georeference", "damage_map", "surface"})
    EXPECT_EQ(StatusOf(stage), "reused") << stage;
  const auto again = Run("--report.ortho_quality 60");
  EXPECT_EQ(StatusOf("report"), "reused");
}

TEST_F(ReportE2E, MissingLeafletFailsTheReportAloneNamingIt) {
  const std::string before = Slurp(Out() / "report" / "index.html");
  const auto r = Run("--report.leaflet_dir " + (root_ / "no-leaflet").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("libjs-leaflet"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find((root_ / "no-leaflet" / "leaflet.js").string()), std::string::npos) << r.output;
  EXPECT_EQ(StatusOf("report"), "failed");
  EXPECT_EQ(StatusOf("surface"), "reused");
  EXPECT_EQ(Slurp(Out() / "report" / "index.html"), before) << "the last good report stays published";
}

TEST_F(ReportE2E, MalformedReferenceTrajectoryNamesFileAndLine) {
  const fs::path bad = root_ / "reference_bad.csv";
  std::ofstream(bad) << "t_ns,lat_deg,lon_deg,h_ellipsoid_m\n1,46.0,15.0,300.0\n2,46.0,fifteen,300.0\n";
  const auto r = Run("--report.reference_trajectory " + bad.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(bad.string() + ":3"), std::string::npos) << r.output;
  EXPECT_EQ(StatusOf("report"), "failed");
}

}  // namespace
}  // namespace rs::test
