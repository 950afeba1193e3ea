#include "stages/disparity/perspective_transform.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace rs {
namespace {

TEST(PerspectiveTransform, Nominal) {
  RoadModel road;
  road.SetRoll(30, 0.05, 0.1);  // d = 30 - 0.005 u + 0.0498 v
  const auto kappa = ComputeGptShift(road, 200, 100, 8.0);
  for (int v : {0, 50, 99}) EXPECT_NEAR(kappa[v], road.At(199, v) - 8.0, 1e-9);  // minimum at the right edge

  // A road-textured row: warping by kappa must align target and reference up to delta.
  cv::Mat tex(100, 400, CV_8U);
  cv::randu(tex, 0, 255);
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), 2.0);
  cv::Mat right(100, 200, CV_8U);
  for (int v = 0; v < 100; ++v)
    for (int x = 0; x < 200; ++x) right.at<uint8_t>(v, x) = tex.at<uint8_t>(v, x + 100);
  const auto k2 = std::vector<double>(100, 12.25);
  const cv::Mat w = WarpTarget(right, k2);
  // I_t'(u) = I_t(u - 12.25) = 0.75 I_t(u - 12) + 0.25 I_t(u - 13)
  for (int v = 0; v < 100; v += 7)
    for (int u = 20; u < 200; u += 13) {
      const double expect = 0.75 * right.at<uint8_t>(v, u - 12) + 0.25 * right.at<uint8_t>(v, u - 13);
      EXPECT_NEAR(w.at<uint8_t>(v, u), expect, 0.51);
    }

  // Back to true disparity and the transformed disparity (eq. 5).
  cv::Mat l(100, 200, CV_32F, cv::Scalar(8.0f)), valid(100, 200, CV_8U, cv::Scalar(255));
  valid.at<uint8_t>(3, 4) = 0;
  const cv::Mat d = TrueFromWarpedDisparity(l, valid, kappa);
  EXPECT_NEAR(d.at<float>(50, 199), road.At(199, 50), 1e-4);
  EXPECT_EQ(d.at<float>(3, 4), 0.0f);
  const cv::Mat t = TransformedDisparity(d, valid, road, 8.0);
  EXPECT_NEAR(t.at<float>(50, 199), 8.0, 1e-4);  // on the row minimum: delta
  EXPECT_NEAR(t.at<float>(50, 0), 8.0 - (road.At(0, 50) - road.At(199, 50)), 1e-4);
}

// Per-pixel warp: every pixel shifted by its own road disparity minus delta, linear weights.
TEST(PerspectiveTransform, PerPixelWarpFollowsTheRoad) {
  cv::Mat right(60, 240, CV_8U);
  cv::RNG rng(3);
  rng.fill(right, cv::RNG::UNIFORM, 0, 256);
  RoadModel road;
  road.SetPlane(30.0, -0.02, 0.05);  // d = 30 - 0.02 u + 0.05 v: a roll along the row
  const double delta = 8.0;
  const cv::Mat w = WarpTargetPerPixel(right, road, delta);
  int checked = 0;
  for (int v = 0; v < 60; v += 5)
    for (int u = 60; u < 240; u += 11) {
      const double x = u - (road.At(u, v) - delta), f = x - std::floor(x);
      const int x0 = static_cast<int>(std::floor(x));
      const double expect = (1 - f) * right.at<uint8_t>(v, x0) + f * right.at<uint8_t>(v, x0 + 1);
      EXPECT_NEAR(w.at<uint8_t>(v, u), expect, 1.01) << u << "," << v;  // 1/256 weights, rounding
      ++checked;
    }
  EXPECT_GT(checked, 100);
  // A road point at u appears in the warped target at u - l with l = delta / (1 - c_u) (planar
  // road: the warp's shift at the matched column differs by c_u l); d = l + s(u - l, v) with
  // s = road - delta gives back road(u, v) exactly.
  const int u = 150, v = 30;
  const double l = delta / (1 - road.c[1]);
  EXPECT_NEAR(l + road.At(u - l, v) - delta, road.At(u, v), 1e-9);
}

// Quadratic (cambered) road: the vectorised source columns (float) give the interpolation with
// weights lround(frac * 256) of the per-pixel formula (double), sampled with border clamping;
// where the float position rounds to the neighbouring 1/256 weight the sample differs by at most
// one grey level, and that is rare.
TEST(PerspectiveTransform, PerPixelWarpQuadraticMatchesFormula) {
  const int W = 203, H = 41;  // odd width: vector loops and their scalar tails both run
  cv::Mat right(H, W, CV_8U);
  cv::RNG rng(5);
  rng.fill(right, cv::RNG::UNIFORM, 0, 256);
  RoadModel road;
  road.SetPlane(25.0, -0.03, 0.07);
  road.quadratic = true;
  road.c[3] = 2.5e-4, road.c[4] = -1e-4, road.c[5] = 3e-4;
  const double delta = 6.0;
  const cv::Mat w = WarpTargetPerPixel(right, road, delta);
  int mismatches = 0, clamped = 0, max_diff = 0;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const double a = road.c[0] + road.c[2] * v + road.c[5] * v * v - delta, b = road.c[1] + road.c[4] * v;
      const double x = u - (a + (b + road.c[3] * u) * u), fl = std::floor(x);
      const int x0 = static_cast<int>(fl), wb = static_cast<int>(std::lround((x - fl) * 256.0));
      const int i0 = std::clamp(x0, 0, W - 1), i1 = std::clamp(x0 + 1, 0, W - 1);
      const int expect = (right.at<uint8_t>(v, i0) * (256 - wb) + right.at<uint8_t>(v, i1) * wb + 128) >> 8;
      mismatches += w.at<uint8_t>(v, u) != expect;
      max_diff = std::max(max_diff, std::abs(w.at<uint8_t>(v, u) - expect));
      clamped += x0 < 0 || x0 + 1 > W - 1;
    }
  EXPECT_LE(max_diff, 1);
  EXPECT_LE(mismatches, W * H / 100);
  EXPECT_GT(clamped, 0);  // the border clamps are exercised
}

TEST(PerspectiveTransform, KappaRowMismatch) {
  cv::Mat img(10, 10, CV_8U, cv::Scalar(0));
  EXPECT_THROW(WarpTarget(img, std::vector<double>(9, 0.0)), std::invalid_argument);
}

}  // namespace
}  // namespace rs
