#include "stages/damage/road/relief_smooth.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

namespace rs {
namespace {

constexpr double kDeg = CV_PI / 180.0;

// Road normal ("up", towards the camera) in the camera frame of a camera pitched `pitch_deg`
// below the horizon (x right, y down, z forward).
Eigen::Vector3d Up(double pitch_deg) { return {0.0, -std::cos(pitch_deg * kDeg), -std::sin(pitch_deg * kDeg)}; }

// Relief of `value` with every pixel valid except a 3×3 hole, depth = 10 × value (mm).
RoadRelief MakeRelief(const cv::Mat& value) {
  RoadRelief r;
  r.transformed_disparity_px = value.clone();
  r.valid_mask = cv::Mat(value.size(), CV_8U, cv::Scalar(255));
  r.valid_mask(cv::Rect(40, 30, 3, 3)).setTo(0);
  r.transformed_disparity_px.setTo(0, r.valid_mask == 0);
  r.depth_below_mm = value * 10.0;
  r.depth_below_mm.setTo(std::numeric_limits<float>::quiet_NaN(), r.valid_mask == 0);
  return r;
}

// Brute-force normalised mean of the valid pixels in a w × h window (beyond the image: none).
float WindowMean(const cv::Mat& value, const cv::Mat& valid, int u, int v, cv::Size k) {
  double sum = 0;
  int n = 0;
  for (int y = v - k.height / 2; y <= v + k.height / 2; ++y)
    for (int x = u - k.width / 2; x <= u + k.width / 2; ++x)
      if (x >= 0 && y >= 0 && x < value.cols && y < value.rows && valid.at<uchar>(y, x))
        sum += value.at<float>(y, x), ++n;
  return static_cast<float>(sum / n);
}

// Elongation against the closed form: a ray depressed by φ below the horizon meets the road
// at h / tan φ; along the column a pixel spans h / sin²φ · dφ, across h / sin φ · du / f / √(1+y²),
// so e = 1 / (sin φ · √(1 + y²)).
TEST(ReliefSmooth, RowElongationOfACarAndANadirCamera) {
  const RectifiedStereo g{1000.0, 640.0, 360.0, 0.3};
  const std::vector<double> car = RoadRowElongation(720, g, Up(15));
  for (const int v : {360, 500, 719}) {
    const double y = (v - 360) / 1000.0, phi = 15 * kDeg + std::atan(y);
    EXPECT_NEAR(car[v], 1.0 / (std::sin(phi) * std::sqrt(1 + y * y)), 0.01 * car[v]) << "row " << v;
  }
  EXPECT_NEAR(car[360], 1.0 / std::sin(15 * kDeg), 0.02);  // 3.86 at the principal row
  EXPECT_EQ(car[0], 1.0);                                  // above the horizon (15° up from the axis: row 92): no road
  const std::vector<double> nadir = RoadRowElongation(720, g, Up(90));
  for (const int v : {0, 360, 719}) EXPECT_NEAR(nadir[v], 1.0, 1e-9);
}

TEST(ReliefSmooth, WindowsKeepTheSampleCountAndAreSquareOnTheRoad) {
  const RectifiedStereo g{1000.0, 640.0, 360.0, 0.3};
  const std::vector<cv::Size> car = ReliefSmoothWindows(720, g, Up(15), 7, true);
  EXPECT_EQ(car[360], cv::Size(17, 3));  // e = 3.86: 7 / √e = 3.6 → 3 rows, 49 / 3 → 17 columns
  EXPECT_EQ(car[0], cv::Size(7, 7));     // no road: the square window
  for (const cv::Size& k : car) EXPECT_TRUE(k.width % 2 == 1 && k.height % 2 == 1);
  for (const cv::Size& k : ReliefSmoothWindows(720, g, Up(90), 7, true)) EXPECT_EQ(k, cv::Size(7, 7));
  for (const cv::Size& k : ReliefSmoothWindows(720, g, Up(15), 7, false)) EXPECT_EQ(k, cv::Size(7, 7));
}

TEST(ReliefSmooth, OneWindowEqualsTheFullFrameBoxFilterAndBandsTheBruteForce) {
  cv::Mat value(80, 120, CV_32F);
  cv::randu(value, 20.0, 40.0);
  // One window everywhere: the same as the normalised box filter of the whole frame.
  RoadRelief one = MakeRelief(value);
  SmoothReliefRows(one, std::vector<cv::Size>(80, cv::Size(7, 7)), 0);
  // Windows changing by bands of rows (as in an oblique view), and a relief starting at row 10
  // of the frame the windows are given for.
  std::vector<cv::Size> windows(90, cv::Size(7, 7));
  for (int v = 0; v < 90; ++v) windows[v] = v < 40 ? cv::Size(17, 3) : v < 65 ? cv::Size(9, 5) : cv::Size(7, 7);
  RoadRelief banded = MakeRelief(value);
  SmoothReliefRows(banded, windows, 10);
  const RoadRelief raw = MakeRelief(value);
  for (int v = 0; v < 80; ++v)
    for (int u = 0; u < 120; ++u) {
      if (!raw.valid_mask.at<uchar>(v, u)) {
        EXPECT_EQ(one.transformed_disparity_px.at<float>(v, u), 0.0f);
        EXPECT_TRUE(std::isnan(banded.depth_below_mm.at<float>(v, u)));
        continue;
      }
      const float a = WindowMean(value, raw.valid_mask, u, v, cv::Size(7, 7));
      EXPECT_NEAR(one.transformed_disparity_px.at<float>(v, u), a, 1e-4);
      EXPECT_NEAR(one.depth_below_mm.at<float>(v, u), 10 * a, 1e-3);
      const float b = WindowMean(value, raw.valid_mask, u, v, windows[v + 10]);
      ASSERT_NEAR(banded.transformed_disparity_px.at<float>(v, u), b, 1e-4) << u << "," << v;
      ASSERT_NEAR(banded.depth_below_mm.at<float>(v, u), 10 * b, 1e-3) << u << "," << v;
    }
  EXPECT_THROW(SmoothReliefRows(banded, windows, 11), std::invalid_argument);  // rows 81..90: none
}

// Noise of σ = 0.05 px and a 2 px step: away from the step the noise is averaged, the pixels at
// the step keep their own values (a rim is not smeared onto the road), the noise is measured.
TEST(ReliefSmooth, StepsStandingOutOfTheNoiseAreKept) {
  cv::Mat value(120, 200, CV_32F);
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.f, 0.05f);
  for (int v = 0; v < value.rows; ++v)
    for (int u = 0; u < value.cols; ++u) value.at<float>(v, u) = (u < 100 ? 30.f : 28.f) + noise(rng);
  const std::vector<cv::Size> windows(120, cv::Size(7, 7));
  RoadRelief r = MakeRelief(value);
  const double sigma = SmoothReliefRows(r, windows, 0, 8.0);
  EXPECT_NEAR(sigma, 0.05, 0.01);           // |raw − mean of 49| has σ·√(48/49)
  for (const int u : {98, 99, 100, 101}) {  // at the step: its own value
    EXPECT_EQ(r.transformed_disparity_px.at<float>(60, u), value.at<float>(60, u));
    EXPECT_EQ(r.depth_below_mm.at<float>(60, u), 10 * value.at<float>(60, u));
  }
  cv::Scalar mean, sd;
  cv::meanStdDev(r.transformed_disparity_px(cv::Rect(10, 50, 60, 40)), mean, sd);
  EXPECT_NEAR(mean[0], 30.0, 0.01);
  EXPECT_LT(sd[0], 0.015);  // averaged: ~σ / 7
  // The step rule off: the step is smeared over the window.
  RoadRelief off = MakeRelief(value);
  EXPECT_EQ(SmoothReliefRows(off, windows, 0), 0.0);
  EXPECT_NEAR(off.transformed_disparity_px.at<float>(60, 99), 30.0 - 2.0 * 3 / 7, 0.05);
  // A given noise is used as it is (RefineRoadRelief reuses the frame's).
  RoadRelief given = MakeRelief(value);
  EXPECT_EQ(SmoothReliefRows(given, windows, 0, 8.0, 0.5), 0.5);  // 8 × 0.5 px: the step is noise
  EXPECT_NEAR(given.transformed_disparity_px.at<float>(60, 99), 30.0 - 2.0 * 3 / 7, 0.05);
}

}  // namespace
}  // namespace rs
