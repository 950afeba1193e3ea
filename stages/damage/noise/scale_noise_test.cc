#include "stages/damage/noise/scale_noise.h"

#include "stages/damage/measure/measure.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace rs {
namespace {

// A nadir view 6 m above a flat road (f = 1000 px, B = 0.3 m: 6 mm per pixel, σ_Z 30 mm for
// σ_d 0.25 px), 480 × 480 px, with one bowl of radius 60 px (0.36 m): flat floor `depth_mm`
// deep over the inner 70 % of the radius, linear wall.
constexpr int kSize = 480;
constexpr double kCentre = 240, kRadiusPx = 60;

RectifiedStereo Geometry() {
  RectifiedStereo g;
  g.f_px = 1000, g.cx_px = kCentre, g.cy_px = kCentre, g.baseline_m = 0.3;
  return g;
}

RoadSurface Surface() {
  RoadSurface s;
  s.origin_m = {0, 0, 6}, s.e1 = Eigen::Vector3d::UnitX(), s.e2 = Eigen::Vector3d::UnitY();
  s.normal = -Eigen::Vector3d::UnitZ(), s.camera_height_m = 6;
  return s;
}

double BowlDepthMm(int u, int v, double depth_mm) {
  const double q = std::hypot(u - kCentre, v - kCentre) / kRadiusPx;
  return depth_mm * std::clamp((1 - q) / 0.3, 0.0, 1.0);
}

// `noise_mm` (CV_32F) added to the bowl; the label is the bowl's opening.
RoadRelief Relief(const cv::Mat& noise_mm, double depth_mm, cv::Mat* labels) {
  RoadRelief r;
  r.depth_below_mm.create(kSize, kSize, CV_32F);
  *labels = cv::Mat::zeros(kSize, kSize, CV_16U);
  for (int v = 0; v < kSize; ++v)
    for (int u = 0; u < kSize; ++u) {
      r.depth_below_mm.at<float>(v, u) = static_cast<float>(BowlDepthMm(u, v, depth_mm) + noise_mm.at<float>(v, u));
      if (std::hypot(u - kCentre, v - kCentre) < kRadiusPx) labels->at<uint16_t>(v, u) = 1;
    }
  r.road_depth_m = cv::Mat(kSize, kSize, CV_32F, cv::Scalar(6.0));
  r.valid_mask = cv::Mat(kSize, kSize, CV_8U, cv::Scalar(255));
  r.obstacle_mask = cv::Mat::zeros(kSize, kSize, CV_8U);
  r.transformed_disparity_px = cv::Mat(kSize, kSize, CV_32F, cv::Scalar(30.0));
  return r;
}

// Short-range matching noise: white noise box-averaged over 7 × 7 (the relief's filter), σ ≈ 6 mm.
cv::Mat ShortRangeNoise() {
  cv::Mat n(kSize, kSize, CV_32F);
  cv::RNG rng(11);
  rng.fill(n, cv::RNG::NORMAL, 0.0, 42.0);
  cv::blur(n, n, {7, 7}, {-1, -1}, cv::BORDER_REFLECT);
  return n;
}

// The per-pixel noise map as the pipeline states it (px of disparity): 0.05 px = 6 mm at 6 m.
cv::Mat NoisePx(double sigma_mm) { return cv::Mat(kSize, kSize, CV_32F, cv::Scalar(sigma_mm / 1000.0 * 300 / 36)); }

// Averaging over a w-wide window divides short-range noise by about w / 7 (7×7 already averaged);
// the bowl's floor keeps its depth.
TEST(MeasureScaleNoise, Nominal) {
  cv::Mat labels;
  const RoadRelief r = Relief(ShortRangeNoise(), 40, &labels);
  const cv::Mat road(kSize, kSize, CV_8U, cv::Scalar(255));
  const cv::Rect box = cv::boundingRect(labels == 1);
  const ScaleNoise one = MeasureScaleNoise(r.depth_below_mm, road, labels, 1, box, 1, 192, 0.999, 0);
  EXPECT_NEAR(one.sigma_mm, 6.0, 0.6);
  const ScaleNoise wide = MeasureScaleNoise(r.depth_below_mm, road, labels, 1, box, 41, 192, 0.999, 0);
  std::printf("sigma 1 px %.2f mm, 41 px %.2f mm; spike %.1f / %.1f mm; depth %.1f / %.1f mm\n", one.sigma_mm,
              wide.sigma_mm, one.spike_mm, wide.spike_mm, one.depth_mm, wide.depth_mm);
  EXPECT_NEAR(wide.sigma_mm, 6.0 * 7 / 41, 0.4);
  EXPECT_LT(wide.spike_mm, 0.25 * one.spike_mm);
  EXPECT_NEAR(wide.depth_mm, 40.0, 2.0);  // the 41-px box fits inside the 84-px floor
  EXPECT_GT(wide.samples, 10000);
}

// A 0.36 m-radius, 32 mm bowl at 6 m in 6 mm of short-range noise fails the per-pixel rule
// (its 99th-percentile depth, noise included, < 8 · 6 mm) but stands ~50 σ out at its own
// scale: a pothole (HEAD: "other"; the obstacles renders' 35–48 mm potholes at 6 m, ours).
TEST(MeasureDepressions, WideShallowPotholeConfirmedAtItsScale) {
  cv::Mat labels;
  const RoadRelief r = Relief(ShortRangeNoise(), 32, &labels);
  const std::vector<DamageInstance> d =
      MeasureDepressions(labels, r, Geometry(), Surface(), MeasureOptions(), NoisePx(6.0));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_LT(1000 * d[0].max_depth_m, 8 * 6.0);  // the per-pixel rule alone would not confirm it
  EXPECT_EQ(d[0].type, DamageType::kPothole);
}

// Long-range errors (pixel-locking ripples following the road's residual, period 200 px) do not
// average out over the bowl's window: a 35 mm bowl in ±6 mm ripples stays "other".
TEST(MeasureDepressions, RipplesStillGuardTheNoiseRule) {
  cv::Mat ripple(kSize, kSize, CV_32F);
  for (int v = 0; v < kSize; ++v)
    for (int u = 0; u < kSize; ++u) ripple.at<float>(v, u) = static_cast<float>(6.0 * std::sin(2 * CV_PI * u / 200.0));
  cv::Mat labels;
  const RoadRelief r = Relief(ripple, 35, &labels);
  const std::vector<DamageInstance> d =
      MeasureDepressions(labels, r, Geometry(), Surface(), MeasureOptions(), NoisePx(6.3));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].type, DamageType::kOther);
  // The same bowl in short-range noise of the same per-pixel σ is confirmed.
  const RoadRelief quiet = Relief(ShortRangeNoise() * (6.3 / 6.0), 35, &labels);
  EXPECT_EQ(MeasureDepressions(labels, quiet, Geometry(), Surface(), MeasureOptions(), NoisePx(6.3))[0].type,
            DamageType::kPothole);
}

// A small depression (core narrower than twice the wrong-winner patches) gets no scale test.
TEST(MeasureDepressions, SmallDepressionKeepsThePerPixelRule) {
  cv::Mat noise = ShortRangeNoise(), labels = cv::Mat::zeros(kSize, kSize, CV_16U);
  RoadRelief r = Relief(noise, 0, &labels);
  labels.setTo(0);
  // A 20-px, 40 mm flat patch (0.12 m wide): its core's inscribed square is < 15 px.
  cv::circle(labels, {100, 100}, 10, cv::Scalar(1), cv::FILLED);
  r.depth_below_mm.setTo(40.0f, labels == 1);
  const std::vector<DamageInstance> d =
      MeasureDepressions(labels, r, Geometry(), Surface(), MeasureOptions(), NoisePx(6.0));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].type, DamageType::kOther);
}

TEST(MeasureScaleNoise, BadInput) {
  const cv::Mat depth(20, 20, CV_32F, cv::Scalar(0)), road(20, 20, CV_8U, cv::Scalar(255));
  const cv::Mat labels = cv::Mat::zeros(20, 20, CV_16U);
  EXPECT_THROW(MeasureScaleNoise(depth, road, labels, 1, {0, 0, 5, 5}, 0, 10, 0.999, 0), std::invalid_argument);
  EXPECT_THROW(MeasureScaleNoise(depth, road, labels, 1, {}, 3, 10, 0.999, 0), std::invalid_argument);
  EXPECT_THROW(MeasureScaleNoise(depth, road, labels, 1, {0, 0, 5, 5}, 3, 10, 1.0, 0), std::invalid_argument);
  EXPECT_THROW(MeasureScaleNoise(depth, road(cv::Rect(0, 0, 10, 10)), labels, 1, {0, 0, 5, 5}, 3, 10, 0.999, 0),
               std::invalid_argument);
  // Too few road windows around it: NaN, not a number that could confirm anything.
  const ScaleNoise s = MeasureScaleNoise(depth, road, labels, 1, {0, 0, 5, 5}, 3, 10, 0.999, 0);
  EXPECT_TRUE(std::isnan(s.sigma_mm));
}

}  // namespace
}  // namespace rs
