#include "stages/damage/measure/measurement_sigma.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace rs {
namespace {

// The boundary pixels of a digital disc, divided by their share per pixel of outline, measure
// its circumference: within 3 % from a radius of 15 px up.
TEST(MeasurementSigma, BoundaryPixelsMeasureTheOutlineLength) {
  for (int radius : {15, 40, 120}) {
    cv::Mat labels = cv::Mat::zeros(300, 300, CV_16U);
    cv::circle(labels, {150, 150}, radius, cv::Scalar(7), cv::FILLED);
    int count = 0;
    for (int v = 0; v < labels.rows; ++v)
      for (int u = 0; u < labels.cols; ++u) count += labels.at<uint16_t>(v, u) == 7 && IsBoundaryPixel(labels, u, v);
    EXPECT_NEAR(count / kBoundaryPixelsPerOutlinePx, 2 * CV_PI * radius, 0.03 * 2 * CV_PI * radius) << radius;
  }
}

TEST(MeasurementSigma, ImageBorderIsBoundary) {
  cv::Mat labels(10, 10, CV_16U, cv::Scalar(3));
  EXPECT_TRUE(IsBoundaryPixel(labels, 0, 5));
  EXPECT_TRUE(IsBoundaryPixel(labels, 9, 9));
  EXPECT_FALSE(IsBoundaryPixel(labels, 5, 5));
}

TEST(MeasurementSigma, OutlineSigmaGrowsWithTheNoiseRatio) {
  MeasureOptions o;  // 1.5 px + 3 px · σ_Z / depth
  EXPECT_DOUBLE_EQ(OutlineSigmaPx(0.100, 0.010, o), 1.5 + 3.0 * 0.1);
  EXPECT_DOUBLE_EQ(OutlineSigmaPx(0.030, 0.030, o), 1.5 + 3.0);
  // Within the noise, unknown or not below the road: capped at twice the noise.
  EXPECT_DOUBLE_EQ(OutlineSigmaPx(0.010, 0.050, o), 1.5 + 6.0);
  EXPECT_DOUBLE_EQ(OutlineSigmaPx(std::nan(""), 0.010, o), 1.5 + 6.0);
  EXPECT_DOUBLE_EQ(OutlineSigmaPx(-0.002, 0.010, o), 1.5 + 6.0);
}

// σ_area: the outline (its boundary pixels' area over their share per outline pixel) moved by σ px.
TEST(MeasurementSigma, AreaSigmaIsTheOutlineMovedBySigma) {
  // A disc of radius 50 px with 1 mm² pixels: circumference 314.2 px, σ 2 px -> 628 mm².
  const double boundary_area = 2 * CV_PI * 50 * kBoundaryPixelsPerOutlinePx * 1e-6;
  EXPECT_NEAR(AreaSigmaM2(boundary_area, 2.0), 2 * 2 * CV_PI * 50 * 1e-6, 1e-12);
  EXPECT_DOUBLE_EQ(AreaSigmaM2(boundary_area, 0.0), 0.0);
}

TEST(MeasurementSigma, VolumeSigmaAddsNoiseAndOutlineInQuadrature) {
  MeasureOptions o;  // 9 px correlation
  // 8100 px = 100 independent 9×9 patches: noise σ_Z·A/10; outline: mean depth × σ_area.
  const double area = 0.2, mean = 0.05, sz = 0.02, sa = 0.01;
  const double expected = std::hypot(sz * area / 10, mean * sa);
  EXPECT_NEAR(VolumeSigmaM3(area, mean, sz, sa, 8100, o), expected, 1e-15);
  // A region smaller than one patch: no averaging.
  EXPECT_NEAR(VolumeSigmaM3(area, mean, sz, 0, 40, o), sz * area, 1e-15);
  // A mean depth above the road moves no volume with the outline.
  EXPECT_NEAR(VolumeSigmaM3(area, -0.01, sz, sa, 8100, o), sz * area / 10, 1e-15);
  EXPECT_TRUE(std::isnan(VolumeSigmaM3(area, std::nan(""), sz, sa, 8100, o)));
}

}  // namespace
}  // namespace rs
