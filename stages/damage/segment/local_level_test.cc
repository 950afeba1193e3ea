#include "stages/damage/segment/local_level.h"
#include "stages/damage/segment/wall_test.h"
#include "eval/damage/damage_eval.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>
#include <stdexcept>

namespace rs {
namespace {

// A 1000 × 700 road at level 1000 with Gaussian noise σ 10, smoothed like stereo disparity
// (3 × 3 box), plus `shape(u, v)`; `truth` (optional) marks where `hole(u, v)` is true.
template <class Shape, class Hole>
ReliefImage Road(Shape shape, Hole hole, cv::Mat* truth) {
  cv::Mat noise(700, 1000, CV_32F);
  cv::randn(noise, 0, 10.0 * 3.0);  // the 3 × 3 box divides white noise's σ by 3
  cv::theRNG().state = 7;
  cv::blur(noise, noise, {3, 3});
  ReliefImage r;
  r.value.create(noise.size(), CV_32F);
  r.valid = cv::Mat(noise.size(), CV_8U, cv::Scalar(255));
  if (truth) *truth = cv::Mat::zeros(noise.size(), CV_8U);
  for (int v = 0; v < noise.rows; ++v)
    for (int u = 0; u < noise.cols; ++u) {
      r.value.at<float>(v, u) = static_cast<float>(1000.0 + noise.at<float>(v, u) + shape(u, v));
      if (truth && hole(u, v)) truth->at<uchar>(v, u) = 255;
    }
  return r;
}

// A steep-walled pothole: 400 px across (12 level cells), 40 σ deep, walls 6 px wide.
double Pothole(double u, double v) {
  const double r = std::hypot(u - 500, v - 350);
  return -400.0 * std::clamp((200.0 - r) / 6.0, 0.0, 1.0);
}

TEST(LocalReliefLevel, FollowsACrownNotAPothole) {
  const auto crown = [](double u, double) { return -300.0 * std::pow((u - 500) / 500.0, 2); };
  const ReliefImage r = Road([&](double u, double v) { return crown(u, v) + Pothole(u, v); },
                             [](double, double) { return false; }, nullptr);
  SegmentOptions o;
  const DepressionSegmentation seg = SegmentOnLocalLevel(r, o);
  ASSERT_EQ(seg.count, 1);
  EXPECT_NEAR(cv::countNonZero(seg.labels), CV_PI * 200 * 200, 0.05 * CV_PI * 200 * 200);
  // The level with the pothole left out follows the crown to within 2 σ at the image edges ...
  cv::Mat exclude = cv::Mat::zeros(r.value.size(), CV_8U);
  cv::circle(exclude, {500, 350}, 216, cv::Scalar(255), cv::FILLED);
  const cv::Mat level = LocalReliefLevel(r, o.level_cell_px, 10.0, 3.0, exclude);
  for (int u : {20, 250, 980}) EXPECT_NEAR(level.at<float>(100, u), 1000.0 + crown(u, 100), 20.0) << u;
  // ... and under the pothole, 400 px across, it stays near the road: filled from the ring
  // around, where the crown has fallen by up to 56 (the fill is flat), hence 4 σ.
  EXPECT_NEAR(level.at<float>(350, 500), 1000.0, 40.0);
}

TEST(SegmentOnLocalLevel, FindsAPotholeTwelveCellsWide) {
  cv::Mat truth;
  const ReliefImage r = Road(Pothole, [](double u, double v) { return Pothole(u, v) < -200.0; }, &truth);
  const DepressionSegmentation seg = SegmentOnLocalLevel(r, SegmentOptions());
  const PixelMetrics m = ComparePixels(seg.labels, truth);
  EXPECT_EQ(seg.count, 1);
  EXPECT_GT(m.recall, 0.95);
  EXPECT_GT(m.precision, 0.95);
}

TEST(SegmentOnLocalLevel, BroadSagAndRutAreRoad) {
  // A sag 300 px wide (Gaussian σ 120 px) 20 σ deep and a rut 150 px wide 10 σ deep along the
  // columns: road shapes, no wall; beside them a steep pothole 120 px across.
  const auto shape = [](double u, double v) {
    const double sag = -200.0 * std::exp(-0.5 * (std::pow(u - 250, 2) + std::pow(v - 300, 2)) / (120.0 * 120.0));
    const double rut = -100.0 * std::exp(-0.5 * std::pow((u - 700) / 60.0, 2));
    const double hole = -300.0 * std::clamp((60.0 - std::hypot(u - 850, v - 550)) / 5.0, 0.0, 1.0);
    return sag + rut + hole;
  };
  cv::Mat truth;
  const ReliefImage r =
      Road(shape, [](double u, double v) { return std::hypot(u - 850, v - 550) < 57.5; }, &truth);
  const DepressionSegmentation seg = SegmentOnLocalLevel(r, SegmentOptions());
  const PixelMetrics m = ComparePixels(seg.labels, truth);
  EXPECT_EQ(seg.count, 1);
  EXPECT_GT(m.f1, 0.9);
  // One level for the image reports the sag and the rut.
  SegmentOptions global;
  global.level_cell_px = 0;
  EXPECT_LT(ComparePixels(SegmentOnLocalLevel(r, global).labels, truth).precision, 0.5);
}

TEST(WallSteepness, SteepHoleAgainstGentleSag) {
  cv::Mat labels(700, 1000, CV_16U, cv::Scalar(0));
  cv::circle(labels, {300, 350}, 80, cv::Scalar(1), cv::FILLED);
  cv::circle(labels, {750, 350}, 150, cv::Scalar(2), cv::FILLED);
  const ReliefImage r = Road(
      [](double u, double v) {
        const double hole = -300.0 * std::clamp((82.0 - std::hypot(u - 300, v - 350)) / 5.0, 0.0, 1.0);
        const double sag = -150.0 * std::exp(-0.5 * (std::pow(u - 750, 2) + std::pow(v - 350, 2)) / (100.0 * 100.0));
        return hole + sag;
      },
      [](double, double) { return false; }, nullptr);
  const ReliefSlope slope = MeasureReliefSlope(r.value, r.valid, labels);
  const std::vector<double> s = WallSteepness(slope, labels, 2);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_GT(s[1], 3.0);
  EXPECT_LT(s[2], 3.0);
  cv::Mat l = labels.clone();
  int count = 2;
  EXPECT_EQ(DropInstancesWithoutWall(&l, &count, s, 3.0), 1);
  EXPECT_EQ(count, 1);
  EXPECT_EQ(l.at<uint16_t>(350, 300), 1);
  EXPECT_EQ(l.at<uint16_t>(350, 750), 0);
}

TEST(LocalReliefLevel, RejectsBadInput) {
  ReliefImage r{cv::Mat(10, 10, CV_32F, cv::Scalar(1)), cv::Mat(10, 10, CV_8U, cv::Scalar(255)), {}};
  EXPECT_THROW(LocalReliefLevel(r, 1, 1.0), std::invalid_argument);
  EXPECT_THROW(LocalReliefLevel(r, 8, 0.0), std::invalid_argument);
  EXPECT_THROW(LocalReliefLevel(r, 8, 1.0, 3.0, cv::Mat(5, 5, CV_8U)), std::invalid_argument);
  r.valid = cv::Mat(9, 10, CV_8U);
  EXPECT_THROW(LocalReliefLevel(r, 8, 1.0), std::invalid_argument);
}

}  // namespace
}  // namespace rs
