// End-to-end behaviour of the refine stage on a small simulated survey: COLMAP's rig bundle
// adjustment lowers the reprojection error without raising the trajectory error against the
// simulator's truth; passthrough when disabled; a clear error without COLMAP. Skipped (with a
// message) where the colmap program is not installed, except the missing-program test.
#include <gtest/gtest.h>
#include <unistd.h>

#include <iostream>

#include "formats/colmap/colmap_io.h"
#include "tests/support/run_program.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

bool HaveColmap() { return std::system("command -v colmap > /dev/null 2>&1") == 0; }

class RefineE2E : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("rs_refine_e2e_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    const auto r = RunProgram("simulate " + (root_ / "survey").string() +
                              " --preset demo --num_frames 40 --image_width 640 --image_height 360 --focal_px 500"
                              " --cx_px 320 --cy_px 180 --progress quiet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    // ingest and slam once; each test runs refine alone on them (--only).
    for (const char* stage : {"ingest", "slam"}) {
      const auto s = Run(stage, "");
      ASSERT_EQ(s.exit_code, 0) << s.output;
    }
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  static ProgramResult Run(const std::string& only, const std::string& extra, const std::string& prefix = "") {
    return RunProgramWith(prefix, "run " + (root_ / "survey" / "survey.json").string() + " --output " +
                                      (root_ / "out").string() + " --only " + only + " --progress quiet " + extra);
  }
  static double AteRmse(const fs::path& estimate) {
    const fs::path json = root_ / "ate.json";
    const auto r = RunProgram("eval trajectory " + estimate.string() + " " +
                              (root_ / "survey" / "truth" / "trajectory.tum").string() + " --json " + json.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return ReadJson(json)["ate_m"]["rmse"].get<double>();
  }
  static nlohmann::json RefineCounts() { return ReadJson(root_ / "out" / "manifest.json")["stages"]["refine"]["counts"]; }

  static fs::path root_;
};
fs::path RefineE2E::root_;

// COLMAP minimises the SLAM's own weighted cost; the SLAM's global BA has usually reached its minimum
// already, so the plain-pixel reprojection RMSE may only stay put (within the 1e-7 rounding of the
// published poses) or fall.
TEST_F(RefineE2E, KeepsOrLowersReprojectionErrorWithoutRaisingAte) {
  if (!HaveColmap()) GTEST_SKIP() << "colmap is not installed (Debian package colmap)";
  const auto r = Run("refine", "");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto counts = RefineCounts();
  EXPECT_TRUE(counts["refined"].get<bool>());
  const double rmse_before = counts["reprojection_rmse_px_before"], rmse_after = counts["reprojection_rmse_px_after"];
  EXPECT_LE(rmse_after, rmse_before * (1 + 1e-5));
  const fs::path out = root_ / "out";
  const double before = AteRmse(out / "trajectory.tum"), after = AteRmse(out / "trajectory_refined.tum");
  std::cout << "reprojection RMSE " << counts["reprojection_rmse_px_before"] << " -> "
            << counts["reprojection_rmse_px_after"] << " px, ATE " << before << " -> " << after << " m\n";
  // Tolerance: 2 % of the SLAM's own error or 1 mm, whichever is larger (different solver, same minimum).
  EXPECT_LE(after, before + std::max(0.02 * before, 0.001)) << "ATE before " << before << " m, after " << after << " m";
  // Every SLAM frame is in the refined trajectory; the published model reads back and COLMAP itself opens it.
  const auto slam_lines = Slurp(out / "trajectory.tum"), refined_lines = Slurp(out / "trajectory_refined.tum");
  EXPECT_EQ(std::count(slam_lines.begin(), slam_lines.end(), '\n'), std::count(refined_lines.begin(), refined_lines.end(), '\n'));
  const ColmapModel model = ReadColmapModel(out / "colmap");
  EXPECT_EQ(model.cameras.size(), 2u);
  EXPECT_EQ(model.images.size(), 2 * counts["keyframes"].get<size_t>());
}

// Our model, text and binary, round-trips through COLMAP's own reader: model_analyzer reports the
// numbers of cameras, images and points we wrote.
TEST_F(RefineE2E, ColmapModelAnalyzerReadsOurModel) {
  if (!HaveColmap()) GTEST_SKIP() << "colmap is not installed (Debian package colmap)";
  ASSERT_EQ(Run("refine", "").exit_code, 0);
  const ColmapModel model = ReadColmapModel(root_ / "out" / "colmap");
  for (ColmapFormat format : {ColmapFormat::kBinary, ColmapFormat::kText}) {
    const fs::path dir = root_ / (format == ColmapFormat::kText ? "model_txt" : "model_bin");
    WriteColmapModel(dir, model, format);
    FILE* pipe = ::popen(("colmap model_analyzer --path " + dir.string() + " 2>&1").c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    std::string out;
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
    ASSERT_EQ(::pclose(pipe), 0) << out;
    EXPECT_NE(out.find("Cameras: 2"), std::string::npos) << out;
    EXPECT_NE(out.find("Images: " + std::to_string(model.images.size())), std::string::npos) << out;
    EXPECT_NE(out.find("Points: " + std::to_string(model.points.size())), std::string::npos) << out;
  }
}

TEST_F(RefineE2E, DisabledPassesSlamThrough) {
  const auto r = Run("refine", "--refine.enabled=false");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path out = root_ / "out";
  EXPECT_FALSE(RefineCounts()["refined"].get<bool>());
  EXPECT_EQ(Slurp(out / "trajectory_refined.tum"), Slurp(out / "trajectory.tum"));
  const auto manifest = ReadJson(out / "manifest.json");
  EXPECT_NE(manifest["stages"]["refine"]["warnings"].dump().find("passed through"), std::string::npos);
}

TEST_F(RefineE2E, MissingColmapIsBadEnvironmentNamingThePackage) {
  for (const auto& [prefix, extra] : std::vector<std::pair<std::string, std::string>>{
           {"", "--refine.colmap_program=/nonexistent/colmap"}, {"PATH=/nonexistent", ""}}) {
    const auto r = Run("refine", extra, prefix);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("Debian package colmap"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("refine.enabled = false"), std::string::npos) << r.output;
  }
}

// A COLMAP that runs and fails is a processing failure (exit 1) naming the command and its log.
TEST_F(RefineE2E, FailingColmapIsAProcessingFailure) {
  const auto r = Run("refine", "--refine.colmap_program=/bin/false");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("/bin/false rig_bundle_adjuster"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("colmap.log"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace rs::test
