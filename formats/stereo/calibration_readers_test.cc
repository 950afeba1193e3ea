#include "formats/stereo/calibration_readers.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

#include "formats/input_error.h"
#include "tests/support/test_data.h"

namespace rs {
namespace {

using rs::test::DataRoot;
namespace fs = std::filesystem;

// Truth for the EuRoC V1_01 pair: ORB-SLAM2's own stereoRectify result, bf / fx_rect
// = 47.90639384423901 / 435.2046959714599 (computed in Python).
constexpr double kEurocBaselineM = 0.1100778421917135;

struct Expected {
  bool ok;
  std::string what;  // ok: format name; rejected: substring of the reason
  double baseline_m = 0;
};

TEST(CalibrationSamples, Nominal) {
  const fs::path root = DataRoot() / "calib_samples";
  RS_REQUIRE_DATA(root);
  const double kKitti0002 = 386.1448 / 718.856, kKitti03 = 387.5744 / 721.5377, kKitti0412 = 379.8145 / 707.0912;
  const std::map<std::string, Expected> table = {
      {"README.txt", {false, "unrecognised"}},
      {"basalt/LICENSE", {false, "unrecognised"}},
      {"basalt/data/euroc_ds_calib.json", {false, "basalt"}},
      {"basalt/data/euroc_eucm_calib.json", {false, "basalt"}},
      {"basalt/data/kitti_config.json", {false, "JSON"}},
      {"open_vins/LICENSE", {false, "unrecognised"}},
      {"open_vins/config/euroc_mav/estimator_config.yaml", {false, "unrecognised"}},
      {"open_vins/config/euroc_mav/kalibr_imu_chain.yaml", {false, "no cameras"}},
      {"open_vins/config/euroc_mav/kalibr_imucam_chain.yaml", {true, "Kalibr camchain", kEurocBaselineM}},
      {"open_vins/config/kaist/estimator_config.yaml", {false, "unrecognised"}},
      {"open_vins/config/kaist/kalibr_imu_chain.yaml", {false, "no cameras"}},
      // KAIST: ~0.475 m car rig; truth from T_imu_cam of both cameras (5-decimal values).
      {"open_vins/config/kaist/kalibr_imucam_chain.yaml", {true, "Kalibr camchain", 0.4751487}},
      {"orb_slam2/LICENSE.txt", {false, "unrecognised"}},
      {"orb_slam2/Examples/Monocular/EuRoC.yaml", {false, "monocular"}},
      {"orb_slam2/Examples/Stereo/EuRoC.yaml", {true, "ORB-SLAM2 settings", kEurocBaselineM}},
      {"orb_slam2/Examples/Stereo/KITTI00-02.yaml", {true, "ORB-SLAM2 settings", kKitti0002}},
      {"orb_slam2/Examples/Stereo/KITTI03.yaml", {true, "ORB-SLAM2 settings", kKitti03}},
      {"orb_slam2/Examples/Stereo/KITTI04-12.yaml", {true, "ORB-SLAM2 settings", kKitti0412}},
      {"stella_vslam/LICENSE", {false, "unrecognised"}},
      {"stella_vslam/example/euroc/EuRoC_mono.yaml", {false, "not a stereo setup"}},
      {"stella_vslam/example/euroc/EuRoC_stereo.yaml", {true, "stella_vslam settings", kEurocBaselineM}},
      {"stella_vslam/example/kitti/KITTI_mono_00-02.yaml", {false, "not a stereo setup"}},
      {"stella_vslam/example/kitti/KITTI_mono_03.yaml", {false, "not a stereo setup"}},
      {"stella_vslam/example/kitti/KITTI_mono_04-12.yaml", {false, "not a stereo setup"}},
      {"stella_vslam/example/kitti/KITTI_stereo_00-02.yaml", {true, "stella_vslam settings", kKitti0002}},
      {"stella_vslam/example/kitti/KITTI_stereo_03.yaml", {true, "stella_vslam settings", kKitti03}},
      {"stella_vslam/example/kitti/KITTI_stereo_04-12.yaml", {true, "stella_vslam settings", kKitti0412}},
  };
  int checked = 0;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    std::string rel = fs::relative(entry.path(), root).generic_string();
    // The per-sequence timestamp lists are all alike; every one must be refused.
    const bool timestamps = rel.find("EuRoC_TimeStamps/") != std::string::npos;
    SCOPED_TRACE(rel);
    auto it = table.find(rel);
    if (!timestamps && it == table.end()) {
      ADD_FAILURE() << "sample without an expectation: " << rel;
      continue;
    }
    const Expected e = timestamps ? Expected{false, "unrecognised"} : it->second;
    ++checked;
    try {
      CalibrationFormat f;
      const StereoCalibration c = ReadStereoCalibration(entry.path(), &f);
      EXPECT_TRUE(e.ok) << "accepted, expected rejection: " << e.what;
      EXPECT_EQ(ToString(f), e.what);
      EXPECT_NEAR(c.BaselineM(), e.baseline_m, 1e-6);
      EXPECT_EQ(c.source_path, entry.path().string());
    } catch (const InputError& err) {
      EXPECT_FALSE(e.ok) << err.what();
      EXPECT_NE(err.message().find(e.what), std::string::npos) << err.what();
      EXPECT_EQ(err.where().path, entry.path().string());
    }
  }
  EXPECT_GE(checked, static_cast<int>(table.size()));
}

// Four files describe the same EuRoC rig through different conventions (body poses,
// camera-IMU transforms, stereoRectify outputs): all must give the same R, t.
TEST(CalibrationSamples, EurocFormatsAgree) {
  const fs::path cs = DataRoot() / "calib_samples";
  const fs::path sensor = DataRoot() / "euroc_v101_micro/tests/data/MicroEurocDataset/mav0/cam0/sensor.yaml";
  RS_REQUIRE_DATA(cs);
  RS_REQUIRE_DATA(sensor);
  const StereoCalibration ref = ReadStereoCalibration(sensor);
  EXPECT_FALSE(ref.rectified);
  EXPECT_EQ(ref.left.width, 752);
  EXPECT_EQ(ref.left.height, 480);
  EXPECT_DOUBLE_EQ(ref.right.cx, 379.999);
  EXPECT_DOUBLE_EQ(ref.left.dist[0], -0.28340811);
  EXPECT_EQ(ref.left.dist[4], 0.0);
  EXPECT_NEAR(ref.BaselineM(), kEurocBaselineM, 1e-9);
  EXPECT_LT(ref.t_right_left[0], -0.11);  // right camera on the +x side of the left one
  for (const char* rel : {"orb_slam2/Examples/Stereo/EuRoC.yaml", "stella_vslam/example/euroc/EuRoC_stereo.yaml",
                          "open_vins/config/euroc_mav/kalibr_imucam_chain.yaml"}) {
    SCOPED_TRACE(rel);
    const StereoCalibration c = ReadStereoCalibration(cs / rel);
    EXPECT_FALSE(c.rectified);
    EXPECT_DOUBLE_EQ(c.left.fx, ref.left.fx);
    EXPECT_DOUBLE_EQ(c.right.cy, ref.right.cy);
    // stereoRectify's R1/R2 are printed with 16 digits: agreement to 1e-8.
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(c.R_right_left[i], ref.R_right_left[i], 1e-8) << i;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.t_right_left[i], ref.t_right_left[i], 1e-9) << i;
  }
}

TEST(KittiCalib, OdometryNominal) {
  const fs::path p = DataRoot() / "kitti_vo_clips/KITTI_sequence_1/calib.txt";
  RS_REQUIRE_DATA(p);
  const StereoCalibration c = ReadStereoCalibration(p);
  EXPECT_TRUE(c.rectified);
  EXPECT_EQ(c.left.width, 0);  // calib.txt carries no image size
  EXPECT_DOUBLE_EQ(c.left.fx, 707.0912);
  EXPECT_DOUBLE_EQ(c.right.cy, 183.1104);
  EXPECT_NEAR(c.t_right_left[0], -379.8145 / 707.0912, 1e-12);
}

TEST(KittiCalib, LabelledWithSize) {
  std::stringstream in(
      "P0: 7.18856e+02 0 6.071928e+02 0 0 7.18856e+02 1.852157e+02 0 0 0 1 0\n"
      "P1: 7.18856e+02 0 6.071928e+02 -3.861448e+02 0 7.18856e+02 1.852157e+02 0 0 0 1 0\n"
      "P2: 7.18856e+02 0 6.071928e+02 4.538225e+01 0 7.18856e+02 1.852157e+02 -1.130887e-01 0 0 1 3.779761e-03\n");
  const StereoCalibration c = ReadKittiOdometryCalib(in, "calib.txt", 1241, 376);
  EXPECT_EQ(c.right.width, 1241);
  EXPECT_NEAR(c.BaselineM(), 386.1448 / 718.856, 1e-12);
}

TEST(KittiCalib, BadLineNamed) {
  std::stringstream in("P0: 1 0 1 0 0 1 1 0 0 0 1 0\nP1: 1 0 1 -1 0 1 x 0 0 0 1 0\n");
  try {
    ReadKittiOdometryCalib(in, "calib.txt");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "calib.txt");
    EXPECT_EQ(e.where().line, 2);
  }
  std::stringstream shortline("P0: 1 0 1 0 0 1 1 0 0 0 1 0\nP1: 1 0 1 -1 0 1\n");
  try {
    ReadKittiOdometryCalib(shortline, "calib.txt");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
    EXPECT_NE(e.message().find("expected 12"), std::string::npos);
  }
}

TEST(KittiCalib, RawCamToCam) {
  const fs::path p = DataRoot() / "kitti_raw_tiny/KITTI_tiny/2011_09_26/calib_cam_to_cam.txt";
  RS_REQUIRE_DATA(p);
  const StereoCalibration c = ReadStereoCalibration(p);
  EXPECT_TRUE(c.rectified);
  EXPECT_EQ(c.left.width, 1242);
  EXPECT_EQ(c.left.height, 375);
  EXPECT_DOUBLE_EQ(c.left.fx, 721.5377);
  // x components of K^-1 P_rect_02[:,3] - K^-1 P_rect_03[:,3] (Python).
  EXPECT_NEAR(c.BaselineM(), 0.5327119287764802, 1e-12);

  std::ifstream in(p);
  const StereoCalibration raw = ReadKittiRawCamToCam(in, p.string(), /*rectified=*/false);
  EXPECT_FALSE(raw.rectified);
  EXPECT_EQ(raw.left.width, 1392);
  EXPECT_DOUBLE_EQ(raw.right.fx, 903.7596);
  EXPECT_DOUBLE_EQ(raw.left.dist[4], -6.770705e-02);
  // T_03 - R_03 R_02^T T_02 (Python).
  EXPECT_NEAR(raw.t_right_left[0], -0.5326005528905813, 1e-6);
  EXPECT_NEAR(raw.t_right_left[1], 0.006586119087260681, 1e-6);
  EXPECT_NEAR(raw.t_right_left[2], -0.00900165326733264, 1e-6);
}

TEST(KalibrCamchain, TcnCnm1) {
  // A Kalibr output (no %YAML header) with a 12 cm baseline and a 2-degree yaw.
  std::stringstream in(
      "cam0:\n  camera_model: pinhole\n  distortion_model: radtan\n  distortion_coeffs: [0.1, -0.2, 0.001, 0.002]\n"
      "  intrinsics: [600.0, 601.0, 320.0, 240.0]\n  resolution: [640, 480]\n"
      "cam1:\n  T_cn_cnm1:\n  - [0.9993908270190958, 0.0, 0.03489949670250097, -0.12]\n  - [0.0, 1.0, 0.0, 0.001]\n"
      "  - [-0.03489949670250097, 0.0, 0.9993908270190958, 0.002]\n  - [0.0, 0.0, 0.0, 1.0]\n"
      "  camera_model: pinhole\n  distortion_model: radtan\n  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]\n"
      "  intrinsics: [602.0, 603.0, 321.0, 241.0]\n  resolution: [640, 480]\n");
  const StereoCalibration c = ReadKalibrCamchain(in, "camchain.yaml");
  EXPECT_DOUBLE_EQ(c.left.fy, 601.0);
  EXPECT_DOUBLE_EQ(c.left.dist[3], 0.002);
  EXPECT_DOUBLE_EQ(c.right.cx, 321.0);
  EXPECT_NEAR(c.R_right_left[2], 0.03489949670250097, 1e-15);
  EXPECT_DOUBLE_EQ(c.t_right_left[0], -0.12);
  EXPECT_DOUBLE_EQ(c.t_right_left[2], 0.002);
}

TEST(KalibrCamchain, BadRotationNamed) {
  std::stringstream in(
      "cam0:\n  camera_model: pinhole\n  distortion_model: radtan\n  distortion_coeffs: [0, 0, 0, 0]\n"
      "  intrinsics: [600.0, 601.0, 320.0, 240.0]\n  resolution: [640, 480]\n"
      "cam1:\n  T_cn_cnm1:\n  - [1.0, 0.1, 0.0, -0.12]\n  - [0.0, 1.0, 0.0, 0.0]\n"
      "  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n"
      "  camera_model: pinhole\n  distortion_model: radtan\n  distortion_coeffs: [0, 0, 0, 0]\n"
      "  intrinsics: [602.0, 603.0, 321.0, 241.0]\n  resolution: [640, 480]\n");
  try {
    ReadKalibrCamchain(in, "camchain.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("cam1.T_cn_cnm1"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find("orthonormal"), std::string::npos) << e.what();
  }
}

TEST(KalibrCamchain, UnsupportedModel) {
  std::stringstream in(
      "cam0:\n  camera_model: pinhole\n  distortion_model: equidistant\n  distortion_coeffs: [0, 0, 0, 0]\n"
      "  intrinsics: [600.0, 601.0, 320.0, 240.0]\n  resolution: [640, 480]\ncam1:\n  camera_model: omni\n");
  try {
    ReadKalibrCamchain(in, "camchain.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("cam0.distortion_model"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rs
