#include "stages/disparity/disparity.h"
#include "eval/disparity/sim_disparity_eval.h"
#include "tests/support/test_data.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "eval/disparity/disparity_eval.h"
#include "formats/disparity/disparity_io.h"

namespace rs {
namespace {

const StereoPairWithTruth& Road720() {
  static const StereoPairWithTruth p = MakeSyntheticRoadPair(SyntheticRoadOptions{});
  return p;
}

StereoPairWithTruth SmallRoad() {
  SyntheticRoadOptions o;
  o.width = 480, o.height = 270, o.c0 = 14, o.cu = -0.01, o.cv = 0.05, o.pothole_u = 260, o.pothole_v = 190,
  o.pothole_radius_px = 40, o.pothole_depth_px = 4;
  return MakeSyntheticRoadPair(o);
}

TEST(Disparity, Nominal) {
  const auto& p = Road720();
  DisparityParams params;  // GPT-SGM defaults
  const DisparityResult r = ComputeDisparity(p.left, p.right, params);
  ASSERT_EQ(r.method_used, DisparityMethod::kGptSgm);
  EXPECT_FALSE(r.fell_back);
  EXPECT_TRUE(r.road.reliable);
  EXPECT_LE(r.num_disparities, 64);
  const DisparityMetrics road = EvaluateDisparity(r.disparity, r.valid, p.gt, p.road);
  EXPECT_LE(road.d1_est, 0.01);  // D1 on road <= 1 %
  EXPECT_GE(road.density, 0.95);
  // Sub-pixel: 0.027 px with the intensity refinement, 0.057 px with SGM's equiangular fit alone.
  EXPECT_LT(road.epe, 0.04);
  // Transformed disparity (eq. 5): road ~ delta, pothole centre ~ delta - depth.
  EXPECT_NEAR(r.transformed.at<float>(520, 700), params.gpt_delta_px - 5.0, 0.3);
  EXPECT_NEAR(r.transformed.at<float>(300, 1200), params.gpt_delta_px, 0.3);
  EXPECT_NEAR(r.transformed.at<float>(100, 100), params.gpt_delta_px, 0.3);
  std::printf("GPT-SGM 1280x720: D1 %.3f %%, density %.1f %%, EPE %.3f px, %d disparities, %.1f ms\n",
              100 * road.d1_est, 100 * road.density, road.epe, r.num_disparities, r.timings.total_ms);
}

TEST(Disparity, GptIntegerRowShift) {
  const auto p = SmallRoad();
  DisparityParams params;
  params.gpt_subpixel_warp = false;
  params.gpt_num_disparities = 32;
  params.gpt_delta_px = 8;
  params.road.min_inliers = 30;
  const DisparityResult r = ComputeDisparity(p.left, p.right, params);
  ASSERT_EQ(r.method_used, DisparityMethod::kGptSgm);
  const DisparityMetrics road = EvaluateDisparity(r.disparity, r.valid, p.gt, p.road);
  EXPECT_LE(road.d1_est, 0.01);
  EXPECT_GE(road.density, 0.9);
}

TEST(Disparity, PlainSgm) {
  const auto p = SmallRoad();
  DisparityParams params;
  params.method = DisparityMethod::kSgm;
  params.num_disparities = 48;
  const DisparityResult r = ComputeDisparity(p.left, p.right, params);
  EXPECT_EQ(r.method_used, DisparityMethod::kSgm);
  const DisparityMetrics road = EvaluateDisparity(r.disparity, r.valid, p.gt, p.road);
  EXPECT_LE(road.d1_est, 0.01);
  EXPECT_GE(road.density, 0.9);
  ASSERT_TRUE(r.road.reliable);  // fitted to the dense result
  EXPECT_NEAR(r.road.At(0, 0), 14, 0.2);
}

TEST(Disparity, UnreliableRoadFallsBack) {
  const auto p = SmallRoad();
  DisparityParams params;
  params.num_disparities = 48;
  params.road.min_inliers = 100000;  // as if flying too high for enough keypoints
  const DisparityResult r = ComputeDisparity(p.left, p.right, params);
  EXPECT_TRUE(r.fell_back);
  EXPECT_EQ(r.method_used, DisparityMethod::kSgm);
  EXPECT_EQ(r.num_disparities, 48);
  EXPECT_LE(EvaluateDisparity(r.disparity, r.valid, p.gt, p.road).d1_est, 0.01);
}

TEST(Disparity, WrongRoadModelFallsBack) {
  // Top 35 % of the rows: a high-contrast plane 20 px nearer than the road (say a lorry's flank),
  // which wins the keypoints; the low-contrast road below then lies outside GPT's small range,
  // the valid share collapses and plain SGM takes over.
  auto road = SmallRoad();
  SyntheticRoadOptions o;
  o.width = 480, o.height = 270, o.c0 = 34, o.cu = -0.01, o.cv = 0.05, o.pothole_radius_px = 1, o.seed = 11;
  const auto flank = MakeSyntheticRoadPair(o);
  cv::Mat l, r;
  road.left.convertTo(l, CV_8U, 0.25, 96);
  road.right.convertTo(r, CV_8U, 0.25, 96);
  const int rows = 95;
  flank.left.rowRange(0, rows).copyTo(l.rowRange(0, rows));
  flank.right.rowRange(0, rows).copyTo(r.rowRange(0, rows));
  DisparityParams params;
  params.num_disparities = 64;
  params.road.min_inliers = 20;
  const DisparityResult r_out = ComputeDisparity(l, r, params);
  EXPECT_TRUE(r_out.fell_back);
  EXPECT_EQ(r_out.method_used, DisparityMethod::kSgm);
  cv::Mat region = road.road.clone();
  region.rowRange(0, rows).setTo(0);
  EXPECT_LE(EvaluateDisparity(r_out.disparity, r_out.valid, road.gt, region).d1_est, 0.02);
  params.gpt_min_valid_fraction = 0;  // without the safeguard the road is lost
  const DisparityResult g = ComputeDisparity(l, r, params);
  EXPECT_FALSE(g.fell_back);
  EXPECT_LT(EvaluateDisparity(g.disparity, g.valid, road.gt, region).density, 0.5);
}

TEST(Disparity, PriorModel) {
  const auto p = SmallRoad();
  DisparityParams params;
  params.road.min_inliers = 30;
  const DisparityResult first = ComputeDisparity(p.left, p.right, params);
  ASSERT_TRUE(first.road.reliable);
  const DisparityResult second = ComputeDisparity(p.left, p.right, params, &first.road);
  EXPECT_TRUE(second.road.reliable);
  EXPECT_NEAR(second.road.At(100, 100), first.road.At(100, 100), 0.05);
}

// Real asphalt (Fan et al. 2021, model3 pair 3 at half size): no truth disparity, so GPT-SGM is
// checked against plain SGM over the full range, an independent search on the unwarped pair.
TEST(Disparity, RealRoadAgreesWithPlainSgm) {
  const std::string dir = (rs::test::DataRoot() / "pothole_recon_fan2021" / "model3").string();
  cv::Mat l = cv::imread(dir + "/left images/L3.png", cv::IMREAD_GRAYSCALE);
  cv::Mat r = cv::imread(dir + "/right images/R3.png", cv::IMREAD_GRAYSCALE);
  if (l.empty() || r.empty()) GTEST_SKIP() << "no pothole_recon_fan2021 data under " << dir << " (set ROADSURVEY_DATA)";
  cv::resize(l, l, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  cv::resize(r, r, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  DisparityParams gpt;
  gpt.gpt_delta_px = 20, gpt.gpt_num_disparities = 48;
  const DisparityResult a = ComputeDisparity(l, r, gpt);
  ASSERT_EQ(a.method_used, DisparityMethod::kGptSgm);
  EXPECT_GT(a.road.num_inliers, 300);
  EXPECT_LT(a.road.residual_rms_px, 0.6);
  DisparityParams plain;
  plain.method = DisparityMethod::kSgm;
  plain.min_disparity = 48, plain.num_disparities = 144;  // covers 66..170 px seen on this pair
  const DisparityResult b = ComputeDisparity(l, r, plain);
  int64_t both = 0, agree = 0, visible = 0, visible_valid = 0;
  for (int v = 0; v < l.rows; ++v)
    for (int u = 0; u < l.cols; ++u) {
      if (u - a.road.At(u, v) >= 0) ++visible, visible_valid += a.valid.at<uint8_t>(v, u) != 0;
      if (!a.valid.at<uint8_t>(v, u) || !b.valid.at<uint8_t>(v, u)) continue;
      ++both;
      agree += std::abs(a.disparity.at<float>(v, u) - b.disparity.at<float>(v, u)) <= 1.0f;
    }
  EXPECT_GT(double(visible_valid) / visible, 0.97);  // density on road visible in both views
  EXPECT_GT(double(agree) / both, 0.98);
  // Undamaged road: the transformed disparity sits at delta (median over valid pixels).
  std::vector<float> t;
  for (int v = 0; v < l.rows / 2; ++v)  // upper half: no pothole there
    for (int u = 0; u < l.cols; ++u)
      if (a.valid.at<uint8_t>(v, u)) t.push_back(a.transformed.at<float>(v, u));
  std::nth_element(t.begin(), t.begin() + t.size() / 2, t.end());
  EXPECT_NEAR(t[t.size() / 2], 20.0, 0.5);
}

// Full resolution (2081x1040, road at 160-330 px) with the defaults: the sparse matching spans the
// whole common field of view, so the road model is found without a hand-set range.
TEST(Disparity, RealRoadFullResolutionDefaults) {
  const std::string dir = (rs::test::DataRoot() / "pothole_recon_fan2021" / "model3").string();
  const cv::Mat l = cv::imread(dir + "/left images/L3.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat r = cv::imread(dir + "/right images/R3.png", cv::IMREAD_GRAYSCALE);
  if (l.empty() || r.empty()) GTEST_SKIP() << "no pothole_recon_fan2021 data under " << dir << " (set ROADSURVEY_DATA)";
  DisparityParams params;
  params.camera_focal_px = 1389.16;  // calibration_rectified.yaml
  const DisparityResult a = ComputeDisparity(l, r, params);
  ASSERT_EQ(a.method_used, DisparityMethod::kGptSgm);
  EXPECT_FALSE(a.fell_back);
  EXPECT_GT(a.road.num_inliers, 500);
  // Rig ~0.66 m above the road (f B / d at the principal point; the paper's rig); nearly level.
  EXPECT_NEAR(1389.16 * 0.119493 / a.road.At(1069.6, 573.8), 0.66, 0.03);
  EXPECT_LT(std::abs(a.road_tilt_rad) * 180 / M_PI, 5.0);
  int64_t visible = 0, visible_valid = 0;  // road point inside the right image
  for (int v = 0; v < l.rows; ++v)
    for (int u = 0; u < l.cols; ++u)
      if (u - a.road.At(u, v) >= 0) ++visible, visible_valid += a.valid.at<uint8_t>(v, u) != 0;
  EXPECT_GT(double(visible_valid) / visible, 0.95);
}

// A road model the tilt check rejects: plain SGM runs over the range the sparse matches span,
// far beyond the configured [0, 48), and finds the road there.
TEST(Disparity, FallbackRangeFromMatches) {
  SyntheticRoadOptions o;
  o.width = 640, o.height = 270, o.c0 = 150, o.cu = -0.01, o.cv = 0.05, o.pothole_u = 400, o.pothole_v = 190,
  o.pothole_radius_px = 40, o.pothole_depth_px = 4;
  const auto p = MakeSyntheticRoadPair(o);
  DisparityParams params;
  params.num_disparities = 48;
  params.road.min_inliers = 30;
  params.camera_focal_px = 800;
  params.max_road_tilt_deg = 0.01;  // any real tilt exceeds it
  const DisparityResult r = ComputeDisparity(p.left, p.right, params);
  EXPECT_TRUE(r.road_tilt_rejected);
  EXPECT_TRUE(r.fell_back);
  ASSERT_EQ(r.method_used, DisparityMethod::kSgm);
  // Truth spans 143.6..163.5 px; the range holds it with the widening, and is far smaller than [0, W).
  EXPECT_LE(r.min_disparity, 143);
  EXPECT_GE(r.min_disparity + r.num_disparities, 164);
  EXPECT_LE(r.num_disparities, 64);
  const DisparityMetrics road = EvaluateDisparity(r.disparity, r.valid, p.gt, p.road);
  EXPECT_LE(road.d1_est, 0.01);
  EXPECT_GE(road.density, 0.9);
  params.fallback_range_from_matches = false;  // the configured range cannot hold the road
  const DisparityResult c = ComputeDisparity(p.left, p.right, params);
  EXPECT_EQ(c.min_disparity, 0);
  EXPECT_EQ(c.num_disparities, 48);
  EXPECT_LT(EvaluateDisparity(c.disparity, c.valid, p.gt, p.road).density, 0.5);
  params.max_road_tilt_deg = 50;  // the default bound: GPT-SGM as usual
  const DisparityResult g = ComputeDisparity(p.left, p.right, params);
  EXPECT_FALSE(g.fell_back);
  EXPECT_EQ(g.method_used, DisparityMethod::kGptSgm);
}

// Oracle: OpenCV's filterSpeckles on the 1/16-px fixed-point copy. Patches of random size and
// level (steps of 0..2 px between neighbours), holes, and runs broken at every kind of step.
TEST(Disparity, FilterSpecklesMatchesOpenCv) {
  const int W = 157, H = 301;
  cv::Mat d(H, W, CV_32F), valid(H, W, CV_8U);
  cv::RNG rng(11);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const int cell = (v / 9) * 1000 + (u / (3 + (v / 9) % 9)) + ((u + v) % 13 == 0 ? 500 : 0);
      d.at<float>(v, u) =
          20.0f + static_cast<float>((cell * 7919) % 23) * 0.6f + static_cast<float>(rng.uniform(0.0, 0.3));
      valid.at<uint8_t>(v, u) = rng.uniform(0, 100) < 8 ? 0 : 255;
    }
  for (const double max_diff : {0.5, 1.0, 2.0}) {
    cv::Mat fixed(H, W, CV_16S);
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u)
        fixed.at<int16_t>(v, u) =
            valid.at<uint8_t>(v, u) ? static_cast<int16_t>(cvRound(d.at<float>(v, u) * 16.0f)) : INT16_MIN;
    cv::filterSpeckles(fixed, INT16_MIN, 40, cvRound(max_diff * 16.0));
    cv::Mat got_d = d.clone(), got_v = valid.clone();
    FilterSpeckles(&got_d, &got_v, 40, max_diff);
    int mismatches = 0, kept = 0, dropped = 0;
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const bool want = fixed.at<int16_t>(v, u) != INT16_MIN;
        mismatches += want != (got_v.at<uint8_t>(v, u) != 0) || (!want && got_d.at<float>(v, u) != 0.0f);
        kept += want, dropped += !want && valid.at<uint8_t>(v, u);
      }
    EXPECT_EQ(mismatches, 0) << "max_diff " << max_diff;
    EXPECT_GT(kept, W * H / 10);  // both outcomes occur
    EXPECT_GT(dropped, W * H / 20);
  }
}

// Naive oracle: median (lower for even counts) of the valid 3x3 neighbours of each valid pixel.
TEST(Disparity, MedianValid3x3MatchesNaive) {
  const int W = 83, H = 29;
  cv::Mat d(H, W, CV_32F), valid(H, W, CV_8U);
  cv::RNG rng(7);
  rng.fill(d, cv::RNG::UNIFORM, 0.0, 50.0);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) valid.at<uint8_t>(v, u) = rng.uniform(0, 10) < 2 ? 0 : 255;
  for (int u = 20; u < 60; ++u)
    valid.at<uint8_t>(10, u) = 255, valid.at<uint8_t>(11, u) = 255, valid.at<uint8_t>(12, u) = 255;
  cv::Mat got = d.clone();
  MedianValid3x3(&got, valid);
  int mismatches = 0;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      float want = d.at<float>(v, u);
      if (valid.at<uint8_t>(v, u)) {
        std::vector<float> n;
        for (int y = std::max(0, v - 1); y <= std::min(H - 1, v + 1); ++y)
          for (int x = std::max(0, u - 1); x <= std::min(W - 1, u + 1); ++x)
            if (valid.at<uint8_t>(y, x)) n.push_back(d.at<float>(y, x));
        std::sort(n.begin(), n.end());
        want = n[(n.size() - 1) / 2];
      }
      mismatches += got.at<float>(v, u) != want;
    }
  EXPECT_EQ(mismatches, 0);
}

// Small-hole filling against its definition: an invalid interior pixel with >= k valid
// 8-neighbours spanning <= max_spread takes their lower median; everything else is untouched.
TEST(Disparity, FillSmallHolesMatchesDefinition) {
  const int W = 67, H = 31, k = 6;
  const double spread = 1.0;
  cv::Mat d(H, W, CV_32F), valid(H, W, CV_8U);
  cv::RNG rng(11);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      // Smooth plane with a noisy patch (spread > 1 px there) so both outcomes occur.
      d.at<float>(v, u) = static_cast<float>(20 + 0.05 * u + (u > 40 ? rng.uniform(0.0, 3.0) : rng.uniform(0.0, 0.4)));
      valid.at<uint8_t>(v, u) = rng.uniform(0, 10) < 2 ? 0 : 255;
    }
  cv::Mat got = d.clone(), got_valid = valid.clone();
  const int64_t filled = FillSmallHoles(&got, &got_valid, k, spread);
  int64_t expected_fills = 0, mismatches = 0;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      float want = d.at<float>(v, u);
      bool want_valid = valid.at<uint8_t>(v, u) != 0;
      if (!want_valid && v > 0 && v + 1 < H && u > 0 && u + 1 < W) {
        std::vector<float> n;
        for (int y = v - 1; y <= v + 1; ++y)
          for (int x = u - 1; x <= u + 1; ++x)
            if (valid.at<uint8_t>(y, x)) n.push_back(d.at<float>(y, x));
        std::sort(n.begin(), n.end());
        if (static_cast<int>(n.size()) >= k && n.back() - n.front() <= spread)
          want = n[(n.size() - 1) / 2], want_valid = true, ++expected_fills;
      }
      mismatches += (got_valid.at<uint8_t>(v, u) != 0) != want_valid || (want_valid && got.at<float>(v, u) != want);
    }
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(filled, expected_fills);
  EXPECT_GT(expected_fills, 20);                              // the fixture exercises filling ...
  EXPECT_LT(cv::countNonZero(got_valid), W * H);              // ... and refusals
  EXPECT_EQ(FillSmallHoles(&got, &got_valid, 0, spread), 0);  // 0 = off
}

// A band-limited texture rendered analytically at any column, so a sub-pixel shift is exact
// (wavelengths 9-30 px along rows, like asphalt after the pipeline's pre-smoothing).
double Texture(double x, double y) {
  return 128 + 40 * std::sin(0.7 * x + 0.3 * y) + 30 * std::sin(0.37 * x - 0.8 * y + 1) +
         25 * std::sin(0.55 * x + 0.55 * y + 2) + 20 * std::cos(0.21 * x + 0.17 * y);
}

// The intensity refinement recovers a sub-pixel shift from integer (pixel-locked) starting values
// without bias towards integers, for every fraction; textureless windows and rejected pixels
// keep their values.
TEST(Disparity, RefineSubpixelRecoversShift) {
  const int W = 160, H = 48;
  for (double frac = 0.0; frac < 0.95; frac += 0.1) {
    const double shift = 5 + frac;  // left u matches target u - shift
    cv::Mat left(H, W, CV_8U), target(H, W, CV_8U);
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        left.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(Texture(u, v));
        target.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(Texture(u + shift, v));
      }
    // Pixel locking at its worst: every pixel starts at the nearest integer.
    cv::Mat d(H, W, CV_32F, cv::Scalar(std::round(shift))), valid(H, W, CV_8U, cv::Scalar(255));
    valid.at<uint8_t>(20, 80) = 0;
    d.at<float>(20, 80) = 0;
    // The pipeline refines on the pre-smoothed images SGM compared (presmooth_sigma_px = 1).
    cv::GaussianBlur(left, left, cv::Size(0, 0), 1.0);
    cv::GaussianBlur(target, target, cv::Size(0, 0), 1.0);
    RefineSubpixel(left, target, &d, valid, 9);
    double sum = 0, worst = 0;
    int n = 0;
    for (int v = 10; v < H - 10; ++v)
      for (int u = 20; u < W - 20; ++u) {
        if (!valid.at<uint8_t>(v, u)) continue;
        const double e = d.at<float>(v, u) - shift;
        sum += e, worst = std::max(worst, std::abs(e)), ++n;
      }
    EXPECT_NEAR(sum / n, 0.0, 0.03) << "fraction " << frac;
    EXPECT_LT(worst, 0.1) << "fraction " << frac;
    EXPECT_EQ(d.at<float>(20, 80), 0.0f);  // invalid: untouched
  }
  // No texture: SGM's value stays.
  cv::Mat flat(H, W, CV_8U, cv::Scalar(90)), d(H, W, CV_32F, cv::Scalar(4.3)), valid(H, W, CV_8U, cv::Scalar(255));
  RefineSubpixel(flat, flat, &d, valid, 9);
  EXPECT_EQ(cv::countNonZero(d != 4.3f), 0);
}

// The smooth window: on a noisy pair with a half-pixel shift (where the small window's noise is
// largest) it lowers the error without bias; where one hard vertical edge disagrees with the
// texture around it (a matching error the pixel grid makes of a hard edge, as along a simulated
// shadow), the edge's pixels take the texture's value instead of the edge's.
// Weak texture (the far road of a forward view: a mean squared slope below the small window's
// gate of 4 grey levels^2 per px^2) under SGM values with horizontal and vertical streaks (4-path
// aggregation on weak texture): the smooth window, gated on its own precision and taken within
// the small window's own uncertainty, removes the streaks; before, both windows left SGM's values
// there (row stripe 0.2 px).
TEST(Disparity, RefineSubpixelSmoothWindowWeakTexture) {
  const int W = 240, H = 100;
  const double shift = 5.3;
  cv::Mat left(H, W, CV_8U), target(H, W, CV_8U);
  cv::RNG rng(11);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      left.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(128 + 0.04 * (Texture(u, v) - 128) + rng.gaussian(0.5));
      target.at<uint8_t>(v, u) =
          cv::saturate_cast<uint8_t>(128 + 0.04 * (Texture(u + shift, v) - 128) + rng.gaussian(0.5));
    }
  cv::GaussianBlur(left, left, cv::Size(0, 0), 1.0), cv::GaussianBlur(target, target, cv::Size(0, 0), 1.0);
  double slope2 = 0;
  for (int v = 0; v < H; ++v)
    for (int u = 1; u + 1 < W; ++u)
      slope2 += std::pow((left.at<uint8_t>(v, u + 1) - left.at<uint8_t>(v, u - 1)) / 2.0, 2);
  slope2 /= H * (W - 2);
  ASSERT_LT(slope2, 4.0) << "the premise: texture below the small window's gate";
  ASSERT_GT(slope2, 0.3);
  // SGM's streaks: +-0.2 px on alternate 3-row stripes, +-0.1 px on 4-column stripes.
  cv::Mat d(H, W, CV_32F), valid(H, W, CV_8U, cv::Scalar(255));
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u)
      d.at<float>(v, u) = static_cast<float>(shift + ((v / 3) % 2 ? 0.2 : -0.2) + ((u / 4) % 2 ? 0.1 : -0.1));
  StereoPairWithTruth p;
  p.gt = cv::Mat(H, W, CV_32F, cv::Scalar(shift));
  p.road = cv::Mat::zeros(H, W, CV_8U);
  p.road(cv::Rect(30, 0, W - 60, H)).setTo(255);
  const std::vector<int> rows = {20, H - 20};
  const auto before = MeasureRoadErrorsByRows(p, d, valid, rows);
  SubpixelRefineOptions o;
  o.smooth_window = 21, o.max_edge_coherence = 0.7;
  RefineSubpixel(left, target, &d, valid, o);
  const auto after = MeasureRoadErrorsByRows(p, d, valid, rows);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_GT(before[0].StripeRms(), 0.15);
  EXPECT_LT(after[0].StripeRms(), 0.03) << "before " << before[0].StripeRms();
  EXPECT_LT(after[0].Epe(), 0.08) << "before " << before[0].Epe();
  EXPECT_LT(std::abs(after[0].SignedMean()), 0.03);
}

TEST(Disparity, RefineSubpixelSmoothWindow) {
  const int W = 200, H = 80;
  const double shift = 5.5;
  auto render = [&](double edge_shift, double edge_contrast, double texture_gain, cv::Mat* left, cv::Mat* target) {
    left->create(H, W, CV_8U), target->create(H, W, CV_8U);
    auto step = [](double x) { return 1.0 / (1.0 + std::exp(-x / 0.5)); };  // ~2 px wide edge at x = 0
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const double t = 128 - 64 * texture_gain;
        left->at<uint8_t>(v, u) =
            cv::saturate_cast<uint8_t>(t + texture_gain * (Texture(u, v) - 64) * 0.5 + edge_contrast * step(u - 100.0));
        target->at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(t + texture_gain * (Texture(u + shift, v) - 64) * 0.5 +
                                                               edge_contrast * step(u + edge_shift - 100.0));
      }
  };
  auto error = [&](const cv::Mat& d, int u0, int u1, double* mean) {
    double s = 0, s2 = 0;
    int n = 0;
    for (int v = 15; v < H - 15; ++v)
      for (int u = u0; u < u1; ++u) {
        const double e = d.at<float>(v, u) - shift;
        s += e, s2 += e * e, ++n;
      }
    *mean = s / n;
    return std::sqrt(s2 / n);
  };
  {
    cv::Mat left, target;
    render(shift, 0, 1, &left, &target);
    cv::Mat noise_l(H, W, CV_16S), noise_t(H, W, CV_16S);
    cv::RNG rng(7);
    rng.fill(noise_l, cv::RNG::NORMAL, 0, 6), rng.fill(noise_t, cv::RNG::NORMAL, 0, 6);
    cv::Mat l16, t16;
    left.convertTo(l16, CV_16S), target.convertTo(t16, CV_16S);
    cv::Mat(l16 + noise_l).convertTo(left, CV_8U), cv::Mat(t16 + noise_t).convertTo(target, CV_8U);
    cv::GaussianBlur(left, left, cv::Size(0, 0), 1.0), cv::GaussianBlur(target, target, cv::Size(0, 0), 1.0);
    double mean_small = 0, mean_smooth = 0;
    cv::Mat d_small(H, W, CV_32F, cv::Scalar(6.0)), valid(H, W, CV_8U, cv::Scalar(255));
    cv::Mat d_smooth = d_small.clone();
    RefineSubpixel(left, target, &d_small, valid, 9);
    SubpixelRefineOptions o;
    o.smooth_window = 21, o.max_edge_coherence = 0.7;
    RefineSubpixel(left, target, &d_smooth, valid, o);
    const double rms_small = error(d_small, 30, W - 30, &mean_small),
                 rms_smooth = error(d_smooth, 30, W - 30, &mean_smooth);
    EXPECT_LT(rms_smooth, 0.7 * rms_small) << "small window rms " << rms_small;
    // No bias beyond the small window's own (one linearised step from 1/2 px away).
    EXPECT_LE(std::abs(mean_smooth), std::abs(mean_small) + 0.01) << "small window mean " << mean_small;
    EXPECT_LT(std::abs(mean_smooth), 0.04);
  }
  {
    // Texture at 5.5 px, a hard edge of 90 grey levels matched at 5.9 px.
    cv::Mat left, target;
    render(shift + 0.4, 90, 0.6, &left, &target);
    cv::GaussianBlur(left, left, cv::Size(0, 0), 1.0), cv::GaussianBlur(target, target, cv::Size(0, 0), 1.0);
    cv::Mat valid(H, W, CV_8U, cv::Scalar(255));
    double mean_on = 0, mean_off = 0;
    SubpixelRefineOptions o;
    o.smooth_window = 21, o.max_edge_coherence = 0.7;
    cv::Mat d_on(H, W, CV_32F, cv::Scalar(6.0)), d_off = d_on.clone();
    RefineSubpixel(left, target, &d_on, valid, o);
    o.max_edge_coherence = 1;  // edge handling off: the edge pulls its pixels towards 5.9
    RefineSubpixel(left, target, &d_off, valid, o);
    const double rms_on = error(d_on, 97, 104, &mean_on), rms_off = error(d_off, 97, 104, &mean_off);
    // Measured: 0.12 px with, 0.27 px without (the texture alone: 0.04-0.05 px at this half-pixel shift).
    EXPECT_LT(rms_on, 0.5 * rms_off) << "mean " << mean_on;
    EXPECT_GT(mean_off, 0.2) << "the test's edge must disagree with the texture";
  }
}

// A painted line (bright, untextured, 22 px wide) on textured road, its hard edges matched
// 0.4 px off the texture (where each camera's pixel grid cut them: the simulator's aliased paint
// and shadow edges). The local mean the refinement subtracts turns each edge into a ramp
// reaching half the box from it; with a 15-px box the ramp carried the edges' error into the
// paint and onto the road beyond the edge band (false potholes along the lines on the obstacles
// preset). The stage's box keeps it near the edge.
TEST(Disparity, RefineSubpixelHighPassNearPaintEdge) {
  const int W = 200, H = 80, paint_begin = 89, paint_end = 111;
  const double shift = 5.5, edge_error = 0.4;
  auto step = [](double x) { return 1.0 / (1.0 + std::exp(-x / 0.3)); };  // a hard edge at x = 0
  cv::Mat left(H, W, CV_8U), target(H, W, CV_8U);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      auto render = [&](double x, double edge_x) {
        const double paint = step(edge_x - paint_begin) * step(paint_end - edge_x);
        return cv::saturate_cast<uint8_t>((1 - paint) * (0.3 * Texture(x, v) + 60) + paint * 200);
      };
      left.at<uint8_t>(v, u) = render(u, u);
      target.at<uint8_t>(v, u) = render(u + shift, u + shift + edge_error);
    }
  cv::GaussianBlur(left, left, cv::Size(0, 0), 1.0), cv::GaussianBlur(target, target, cv::Size(0, 0), 1.0);
  // Mean |error| over the road 4-15 px from either edge.
  auto band_error = [&](int highpass) {
    cv::Mat d(H, W, CV_32F, cv::Scalar(6.0)), valid(H, W, CV_8U, cv::Scalar(255));
    SubpixelRefineOptions o;
    o.smooth_window = 21, o.max_edge_coherence = 0.7, o.highpass = highpass;
    RefineSubpixel(left, target, &d, valid, o);
    double sum = 0;
    int n = 0;
    for (int v = 15; v < H - 15; ++v)
      for (int k = 4; k <= 15; ++k)
        for (const int u : {paint_begin - k, paint_end + k - 1}) sum += std::abs(d.at<float>(v, u) - shift), ++n;
    return sum / n;
  };
  const double wide = band_error(15), stage = band_error(DisparityParams().refine_highpass_px);
  // Measured: 0.064 px with the 15-px box, 0.019 with the stage's 9 (7: 0.021).
  EXPECT_GT(wide, 0.05) << "the premise: a 15-px box carries the edge error beyond the edge band";
  EXPECT_LT(stage, 0.03) << "15-px box: " << wide;
}

// A rectangular pothole 0.7 px deeper than the road (its four walls vertical steps of disparity)
// on a noisy textured pair, from pixel-locked starting values. The centred windows average both
// sides of a wall, spreading the step over the window's half-width on either side (the 9x9
// window 4 px, the 21x21 one up to 10 px where it agrees with the 9x9 value within its bound);
// the shiftable windows take, beside a wall, the window on the pixel's own side. Edge spread:
// the farthest a pixel off by more than a quarter of the step lies from the nearest wall.
// A textured road at disparity `road` px with a flat-floored pothole `pothole` at `floor` px (each
// view's noise 2 grey levels, seeded, both views blurred by 1 px like the stage's pre-smoothing),
// and SGM's integer winners: the exact disparity rounded.
struct PotholePair {
  cv::Mat left, target, sgm, valid;
};
PotholePair RenderPotholePair(int W, int H, double road, double floor, const cv::Rect& pothole, uint64_t seed) {
  constexpr double kNoise = 2.0;  // grey levels, each view
  PotholePair p{cv::Mat(H, W, CV_8U), cv::Mat(H, W, CV_8U), cv::Mat(H, W, CV_32F),
                cv::Mat(H, W, CV_8U, cv::Scalar(255))};
  cv::RNG rng(seed);
  for (int v = 0; v < H; ++v)
    for (int x = 0; x < W; ++x) {
      // Target column x shows the left column u with u - d(u) = x: the floor's where that lands inside.
      const double u_in = x + floor;
      const double u = pothole.contains(cv::Point(static_cast<int>(std::floor(u_in)), v)) ? u_in : x + road;
      p.left.at<uint8_t>(v, x) = cv::saturate_cast<uint8_t>(Texture(x, v) + rng.gaussian(kNoise));
      p.target.at<uint8_t>(v, x) = cv::saturate_cast<uint8_t>(Texture(u, v) + rng.gaussian(kNoise));
    }
  cv::GaussianBlur(p.left, p.left, cv::Size(0, 0), 1.0), cv::GaussianBlur(p.target, p.target, cv::Size(0, 0), 1.0);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u)
      p.sgm.at<float>(v, u) = static_cast<float>(std::round(pothole.contains(cv::Point(u, v)) ? floor : road));
  return p;
}

TEST(Disparity, RefineSubpixelShiftableWindowsKeepPotholeWalls) {
  const int W = 240, H = 140;
  const double road = 5.3, floor = 4.6;  // px; the pothole: columns [90, 150), rows [40, 100)
  const cv::Rect pothole(90, 40, 60, 60);
  auto truth = [&](int u, int v) { return pothole.contains(cv::Point(u, v)) ? floor : road; };
  const PotholePair pair = RenderPotholePair(W, H, road, floor, pothole, 5);
  const cv::Mat &left = pair.left, &target = pair.target, &d0 = pair.sgm, &valid = pair.valid;
  // Edge spread (px) and the RMS error of the road and floor more than 12 px from any wall.
  auto measure = [&](const cv::Mat& d, double* rms_far) {
    int spread = 0;
    double s2 = 0;
    int n = 0;
    for (int v = 12; v < H - 12; ++v)
      for (int u = 12; u < W - 12; ++u) {
        const int du = std::min(std::abs(u - pothole.x), std::abs(u - pothole.br().x));
        const int dv = std::min(std::abs(v - pothole.y), std::abs(v - pothole.br().y));
        // Distance to the nearest wall (the rectangle's outline).
        const bool in_rows = v >= pothole.y && v < pothole.br().y, in_cols = u >= pothole.x && u < pothole.br().x;
        const int dist = in_rows && in_cols ? std::min(du, dv) : in_rows ? du : in_cols ? dv : std::max(du, dv);
        const double e = d.at<float>(v, u) - truth(u, v);
        if (std::abs(e) > 0.25 * (road - floor)) spread = std::max(spread, dist + 1);
        if (dist > 12) s2 += e * e, ++n;
      }
    *rms_far = std::sqrt(s2 / n);
    return spread;
  };
  SubpixelRefineOptions o;
  o.smooth_window = 21, o.max_edge_coherence = 0.7, o.highpass = DisparityParams().refine_highpass_px;
  cv::Mat d_centred = d0.clone(), d_shift = d0.clone();
  RefineSubpixel(left, target, &d_centred, valid, o);
  o.shift_ratio = DisparityParams().refine_shift_ratio;
  ASSERT_GT(o.shift_ratio, 0) << "the stage's default has the shiftable windows on";
  RefineSubpixel(left, target, &d_shift, valid, o);
  double rms_centred = 0, rms_shift = 0;
  const int spread_centred = measure(d_centred, &rms_centred), spread_shift = measure(d_shift, &rms_shift);
  // Measured: 9 px centred (the 21x21 window's reach), 5 px shiftable: within 4 px of a wall the
  // 9x9 window's own straddle (at most 0.15 px here) and the 21x21 one's, where the per-pixel
  // estimates' spread (noise plus the one Gauss-Newton step's linearisation error) keeps the
  // ratio below refine_shift_ratio, remain.
  EXPECT_GE(spread_centred, 8) << "the premise: centred windows spread the walls";
  EXPECT_LE(spread_shift, 5) << "centred windows: " << spread_centred << " px";
  // Away from the walls the road's noise does not grow.
  EXPECT_LT(rms_shift, 1.1 * rms_centred + 0.002) << "centred " << rms_centred;
  EXPECT_LT(rms_shift, 0.05);
}

// GroundWindowRows against the closed form: a camera pitched t below the horizon, h above a flat
// road, sees row v at depression-angle sine sin t + cos t (v - cy)/f (small columns offsets aside),
// d = (f B/h)(that); the window's height is the odd number nearest 9 times it, within [5, 9].
TEST(Disparity, GroundWindowRowsSquareOnTheRoad) {
  const int W = 1280, H = 720;
  const double f = 1000, B = 0.3, h = 1.5, cy = (H - 1) / 2.0;
  auto nearest_odd = [](double x) {
    int best = 1;
    for (int k = 1; k <= 15; k += 2)
      if (std::abs(k - x) < std::abs(best - x)) best = k;
    return best;
  };
  for (const double pitch_deg : {15.0, 45.0}) {
    const double t = pitch_deg * CV_PI / 180;
    RoadModel road;
    road.SetPlane(f * B / h * std::sin(t) - B / h * std::cos(t) * cy, 0.0, B / h * std::cos(t));
    const std::vector<int> rows = GroundWindowRows(road, W, H, f, 9);
    ASSERT_EQ(rows.size(), static_cast<size_t>(H));
    for (int v = 0; v < H; ++v) {
      const double aspect = std::sin(t) + std::cos(t) * (v - cy) / f;
      const int expected = aspect <= 0 || aspect >= 1 ? 9 : std::clamp(nearest_odd(9 * aspect), 5, 9);
      ASSERT_EQ(rows[v], expected) << "pitch " << pitch_deg << " row " << v << " aspect " << aspect;
    }
    if (pitch_deg == 15) {
      EXPECT_EQ(rows[0], 9);      // above the horizon
      EXPECT_EQ(rows[H / 2], 5);  // 6 m ahead: a ground square is 0.26 as tall as wide
    } else {
      EXPECT_EQ(rows[H / 2], 7);
    }
  }
  // Nadir (no gradient) and an unknown focal length keep the square window.
  RoadModel nadir;
  nadir.SetPlane(50.0, 0.0, 0.0);
  for (int r : GroundWindowRows(nadir, W, H, f, 9)) ASSERT_EQ(r, 9);
  RoadModel pitched;
  pitched.SetPlane(20.0, 0.0, 0.05);
  for (int r : GroundWindowRows(pitched, W, H, 0.0, 9)) ASSERT_EQ(r, 9);
}

// A pothole foreshortened by an oblique view (60 px wide, 12 rows tall): the square 9x9 window
// straddles its near and far walls from 4 rows away; the 9x5 window (GroundWindowRows) from 2.
// Measured on the rows' spread (|error| > a quarter of the depth, rows from the walls).
TEST(Disparity, RefineSubpixelGroundWindowKeepsForeshortenedWalls) {
  const int W = 240, H = 140;
  const double road = 5.3, floor = 4.6;
  const cv::Rect pothole(90, 60, 60, 12);
  auto truth = [&](int u, int v) { return pothole.contains(cv::Point(u, v)) ? floor : road; };
  const PotholePair pair = RenderPotholePair(W, H, road, floor, pothole, 7);
  const cv::Mat &left = pair.left, &target = pair.target, &d0 = pair.sgm, &valid = pair.valid;
  // Largest row distance from the near or far wall (columns 10 px inside the side walls) with an error above
  // a quarter of the depth.
  auto row_spread = [&](const cv::Mat& d) {
    int spread = 0;
    for (int v = 20; v < H - 20; ++v)
      for (int u = pothole.x + 10; u < pothole.br().x - 10; ++u)
        if (std::abs(d.at<float>(v, u) - truth(u, v)) > 0.25 * (road - floor)) {
          const int dist = v < pothole.y         ? pothole.y - v
                           : v >= pothole.br().y ? v - pothole.br().y + 1
                                                 : std::min(v - pothole.y + 1, pothole.br().y - v);
          spread = std::max(spread, dist);
        }
    return spread;
  };
  SubpixelRefineOptions o;
  o.highpass = DisparityParams().refine_highpass_px;
  cv::Mat d_square = d0.clone(), d_ground = d0.clone();
  RefineSubpixel(left, target, &d_square, valid, o);
  o.window_rows.assign(H, 5);
  RefineSubpixel(left, target, &d_ground, valid, o);
  const int spread_square = row_spread(d_square), spread_ground = row_spread(d_ground);
  std::printf("rows spread: square %d, 9x5 %d\n", spread_square, spread_ground);
  EXPECT_GE(spread_square, 4) << "the premise: the square window spreads the near and far walls";
  EXPECT_LE(spread_ground, 2);
}

TEST(Disparity, BadParams) {
  DisparityParams params;
  params.p1 = 8;
  params.p2 = 5;
  try {
    params.Check();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "disparity.p2 = 5 violates p2 > p1 (p1 = 8)");
  }
  params = DisparityParams{};
  params.gpt_delta_px = 60;
  EXPECT_THROW(params.Check(), std::invalid_argument);
  params = DisparityParams{};
  params.census_width = 11;
  EXPECT_THROW(params.Check(), std::invalid_argument);
  params = DisparityParams{};
  params.refine_window = 8;  // even
  EXPECT_THROW(params.Check(), std::invalid_argument);
  params = DisparityParams{};
  params.refine_smooth_window = 20;  // even
  EXPECT_THROW(params.Check(), std::invalid_argument);
  params = DisparityParams{};
  params.refine_max_coherence = 0;
  EXPECT_THROW(params.Check(), std::invalid_argument);
  params = DisparityParams{};
  params.refine_highpass_px = 8;  // even
  try {
    params.Check();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "disparity.refine_highpass_px = 8 violates refine_highpass_px odd, 3 <= refine_highpass_px <= 63");
  }
  cv::Mat a(20, 20, CV_8UC3);
  EXPECT_THROW(ComputeDisparity(a, a, DisparityParams{}), std::invalid_argument);
}

TEST(Disparity, KittiPngRoundTrip) {
  cv::Mat d(3, 4, CV_32F, cv::Scalar(0)), valid(3, 4, CV_8U, cv::Scalar(255));
  d.at<float>(0, 0) = 12.3456f, d.at<float>(1, 2) = 200.0f, d.at<float>(2, 3) = 300.0f;
  valid.at<uint8_t>(0, 1) = 0;
  const auto path = (std::filesystem::temp_directory_path() / "rs_disparity_kitti_test.png").string();
  WriteKittiDisparityPng(path, d, valid);
  cv::Mat back, back_valid;
  FromKittiDisparity16(cv::imread(path, cv::IMREAD_UNCHANGED), &back, &back_valid);
  std::filesystem::remove(path);
  EXPECT_NEAR(back.at<float>(0, 0), 12.3456f, 1.0 / 512);
  EXPECT_EQ(ToKittiDisparity16(d, valid).at<uint16_t>(0, 0), 3160);  // round(12.3456 * 256)
  EXPECT_NEAR(back.at<float>(1, 2), 200.0f, 1e-6);
  EXPECT_NEAR(back.at<float>(2, 3), 65535.0 / 256, 1e-6);  // clamped to 16 bits
  EXPECT_EQ(back_valid.at<uint8_t>(0, 1), 0);              // invalid
  EXPECT_EQ(back_valid.at<uint8_t>(1, 1), 0);              // d = 0 cannot be stored
  const cv::Mat c = ColorizeDisparity(d, valid, 0, 255);
  EXPECT_EQ(c.rows, 3);
  EXPECT_EQ(c.at<cv::Vec3b>(0, 1), cv::Vec3b(0, 0, 0));
}

}  // namespace
}  // namespace rs
