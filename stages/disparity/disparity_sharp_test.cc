// The disparity stage's second image (DisparityResult::disparity_sharp): the small refinement
// window's value alone, before the 21x21 smooth window is taken.
#include "stages/disparity/disparity.h"
#include "sim/synthetic_road_pair.h"
#include "formats/disparity/disparity_io.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace rs {
namespace {

// A paraboloid pothole (sloping walls, 0.2 px/px at the rim) on a textured road.
StereoPairWithTruth PotholeRoad() {
  SyntheticRoadOptions o;
  o.width = 480, o.height = 270, o.c0 = 14, o.cu = -0.01, o.cv = 0.05, o.pothole_u = 240, o.pothole_v = 150,
  o.pothole_radius_px = 40, o.pothole_depth_px = 4;
  return MakeSyntheticRoadPair(o);
}

// Mean of truth - estimate (> 0: deeper than the truth) over valid pixels whose distance r from
// the pothole's centre lies in [r0, r1).
double MeanDeeper(const cv::Mat& d, const cv::Mat& valid, const cv::Mat& gt, double r0, double r1) {
  double sum = 0;
  int n = 0;
  for (int v = 0; v < d.rows; ++v)
    for (int u = 0; u < d.cols; ++u) {
      const double r = std::hypot(u - 240.0, v - 150.0);
      if (r < r0 || r >= r1 || !valid.at<uint8_t>(v, u) || !(gt.at<float>(v, u) > 0)) continue;
      sum += gt.at<float>(v, u) - d.at<float>(v, u), ++n;
    }
  return n ? sum / n : NAN;
}

// The window value RefineSubpixel hands out is the small window's pass alone: bit-identical to a
// refinement without the smooth window, while the result itself takes the smooth window's value.
TEST(DisparitySharp, WindowValueIsTheSmallWindowAlone) {
  const StereoPairWithTruth p = PotholeRoad();
  // Pixel-locked SGM values to refine (the same input for both runs).
  cv::Mat d0 = p.gt.clone(), valid = p.gt > 0;
  for (int v = 0; v < d0.rows; ++v)
    for (int u = 0; u < d0.cols; ++u) d0.at<float>(v, u) = std::round(d0.at<float>(v, u));
  SubpixelRefineOptions small;
  small.window = 9;
  cv::Mat d_small = d0.clone();
  RefineSubpixel(p.left, p.right, &d_small, valid, small);
  SubpixelRefineOptions both = small;
  both.smooth_window = 21, both.max_edge_coherence = 0.7, both.shift_ratio = 4;
  cv::Mat d_both = d0.clone(), window;
  RefineSubpixel(p.left, p.right, &d_both, valid, both, &window);
  ASSERT_EQ(window.size(), d0.size());
  EXPECT_EQ(cv::norm(window, d_small, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(d_both, d_small, cv::NORM_INF), 0.01) << "the smooth window must have changed something";
  // Without a smooth window the window value is the result.
  cv::Mat d_again = d0.clone(), window_again;
  RefineSubpixel(p.left, p.right, &d_again, valid, small, &window_again);
  EXPECT_EQ(cv::norm(window_again, d_again, cv::NORM_INF), 0.0);
}

// ComputeDisparity's sharp image: same validity as the disparity, close to it on the road, and
// at a sloping pothole wall without the smooth window's spread: the road just outside the rim is
// not pulled down and the floor near the wall not pulled up.
TEST(DisparitySharp, KeepsTheWallWhereTheSmoothWindowSpreadsIt) {
  const StereoPairWithTruth p = PotholeRoad();
  const DisparityResult r = ComputeDisparity(p.left, p.right, DisparityParams());
  ASSERT_EQ(r.method_used, DisparityMethod::kGptSgm);
  ASSERT_EQ(r.disparity_sharp.size(), r.disparity.size());
  ASSERT_EQ(r.disparity_sharp.type(), CV_32F);
  EXPECT_EQ(cv::countNonZero((r.disparity_sharp > 0) != (r.valid != 0)), 0) << "same validity";
  cv::Mat diff;
  cv::absdiff(r.disparity_sharp, r.disparity, diff);
  const double mean_diff = cv::mean(diff, r.valid)[0];
  EXPECT_GT(mean_diff, 0.001) << "a second image, not a copy";
  EXPECT_LT(mean_diff, 0.1);
  const double out_smooth = MeanDeeper(r.disparity, r.valid, p.gt, 41, 47);
  const double out_sharp = MeanDeeper(r.disparity_sharp, r.valid, p.gt, 41, 47);
  const double in_smooth = MeanDeeper(r.disparity, r.valid, p.gt, 28, 38);
  const double in_sharp = MeanDeeper(r.disparity_sharp, r.valid, p.gt, 28, 38);
  std::printf("road 1-6 px outside: smooth %.3f px deeper, sharp %.3f; wall 2-12 px inside: smooth %.3f, sharp %.3f\n",
              out_smooth, out_sharp, in_smooth, in_sharp);
  EXPECT_LT(out_sharp, out_smooth);
  EXPECT_GT(in_sharp, in_smooth);
  // Plain SGM (and refine_smooth_window 0): one image.
  DisparityParams plain;
  plain.method = DisparityMethod::kSgm;
  EXPECT_TRUE(ComputeDisparity(p.left, p.right, plain).disparity_sharp.empty());
  DisparityParams no_smooth;
  no_smooth.refine_smooth_window = 0;
  EXPECT_TRUE(ComputeDisparity(p.left, p.right, no_smooth).disparity_sharp.empty());
}

// The stage writes the sharp image as KITTI 16-bit (1/256 px): it reads back within half a step.
TEST(DisparitySharp, KittiRoundTrip) {
  const StereoPairWithTruth p = PotholeRoad();
  const DisparityResult r = ComputeDisparity(p.left, p.right, DisparityParams());
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("rs_sharp_" + std::to_string(::getpid()) + ".png");
  WriteKittiDisparityPng(path.string(), r.disparity_sharp, r.valid);
  cv::Mat back, back_valid;
  FromKittiDisparity16(cv::imread(path.string(), cv::IMREAD_UNCHANGED), &back, &back_valid);
  std::filesystem::remove(path);
  EXPECT_EQ(cv::countNonZero(back_valid != r.valid), 0);
  cv::Mat diff;
  cv::absdiff(back, r.disparity_sharp, diff);
  double worst = 0;
  cv::minMaxLoc(diff, nullptr, &worst, nullptr, nullptr, r.valid);
  EXPECT_LE(worst, 0.5 / 256 + 1e-6);
}

}  // namespace
}  // namespace rs
