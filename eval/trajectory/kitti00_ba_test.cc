#include "eval/trajectory/kitti00_ba.h"
#include "tests/support/test_data.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "formats/input_error.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

// The global BA on 52 544 real KITTI 00 stereo observations: it converges (the reprojection median
// falls), rejects few observations and keeps the trajectory where the measurements put it.
TEST(Kitti00StereoVoBa, GlobalBaOnRealMeasurements) {
  const fs::path data = test::DataRoot();
  RS_REQUIRE_DATA(data / "kitti_euroc_trajectories/gtsam/examples/Data");
  const StereoVoBaReport r = RunKitti00StereoVoBa(data);
  EXPECT_EQ(r.poses, 77);
  EXPECT_EQ(r.observations, 52544);
  // Measured 0.226 -> 0.159 px, 206 rejected (0.4 %).
  EXPECT_LT(r.reproj_median_after_px, 0.8 * r.reproj_median_before_px);
  EXPECT_LT(r.outliers_removed, r.observations / 100);
  // The poses move little against KITTI's ground truth (measured 0.367 -> 0.384 m SE(3) ATE): the
  // measurements themselves carry the visual odometry's start-up error.
  EXPECT_LT(std::abs(r.ate_after_m - r.ate_before_m), 0.1);
}

TEST(Kitti00StereoVoBa, MalformedFilesNameFileAndLine) {
  const fs::path dir = fs::temp_directory_path() / "rs_kitti00_ba_test";
  fs::create_directories(dir);
  std::ofstream(dir / "calib.txt") << "718.856 718.856 0.0 607.1928 185.2157 0.537";
  std::ofstream(dir / "poses.txt") << "0 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n2 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n";
  std::ofstream(dir / "factors.txt") << "0 7 322.5 299.5 11.7 -6.6 -4.1 16.8\n";
  try {
    ReadGtsamStereoVo(dir / "calib.txt", dir / "poses.txt", dir / "factors.txt", 1241, 376);
    FAIL() << "pose id 2 after 0 accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
    EXPECT_NE(std::string(e.what()).find("poses.txt"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "poses.txt", std::ios::trunc) << "0 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\n";
  std::ofstream(dir / "factors.txt", std::ios::trunc) << "0 7 322.5 299.5 11.7 -6.6 -4.1\n";
  EXPECT_THROW(ReadGtsamStereoVo(dir / "calib.txt", dir / "poses.txt", dir / "factors.txt", 1241, 376), InputError);
  std::ofstream(dir / "factors.txt", std::ios::trunc) << "3 7 322.5 299.5 11.7 -6.6 -4.1 16.8\n";
  EXPECT_THROW(ReadGtsamStereoVo(dir / "calib.txt", dir / "poses.txt", dir / "factors.txt", 1241, 376), InputError);
  const StereoVoProblem ok = [&] {
    std::ofstream(dir / "factors.txt", std::ios::trunc) << "0 7 322.5 299.5 11.7 -6.6 -4.1 16.8\n";
    return ReadGtsamStereoVo(dir / "calib.txt", dir / "poses.txt", dir / "factors.txt", 1241, 376);
  }();
  EXPECT_DOUBLE_EQ(ok.camera.baseline_m, 0.537);
  EXPECT_DOUBLE_EQ(ok.camera.cy_px, 185.2157);
  ASSERT_EQ(ok.observations.size(), 1u);
  EXPECT_DOUBLE_EQ(ok.observations[0].p_cam.z(), 16.8);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rs
