#include "stages/damage/noise/relief_noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

namespace rs {
namespace {

// Road at level 30 with σ = 0.1 on the left half and 0.3 on the right, a 0.5-deep bowl of radius
// 60 px in the right half and an invalid strip: the map must follow each half's noise, ignore
// the bowl (it only fills the lower tail) and fill the strip from its neighbours.
TEST(ReliefNoise, Nominal) {
  cv::Mat value(480, 768, CV_32F), valid(value.size(), CV_8U, cv::Scalar(255));
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0.f, 1.f);
  for (int v = 0; v < value.rows; ++v)
    for (int u = 0; u < value.cols; ++u) {
      const double sigma = u < 384 ? 0.1 : 0.3;
      const double bowl = std::hypot(u - 580, v - 240) < 60 ? 0.5 : 0.0;
      value.at<float>(v, u) = static_cast<float>(30.0 - bowl + sigma * n(rng));
    }
  valid(cv::Rect(0, 0, 768, 100)).setTo(0);
  const cv::Mat s = LocalReliefNoise(value, valid, 30.0, 96, 0.05);
  ASSERT_EQ(s.type(), CV_32FC1);
  ASSERT_EQ(s.size(), value.size());
  EXPECT_NEAR(s.at<float>(300, 100), 0.1, 0.01);
  EXPECT_NEAR(s.at<float>(300, 700), 0.3, 0.03);
  EXPECT_NEAR(s.at<float>(240, 580), 0.3, 0.03);  // the bowl's centre: road noise, not its depth
  EXPECT_NEAR(s.at<float>(20, 100), 0.1, 0.01);   // no valid pixel: from the cells below
  // Floor.
  const cv::Mat f = LocalReliefNoise(value, valid, 30.0, 96, 0.2);
  EXPECT_NEAR(f.at<float>(300, 100), 0.2, 1e-6);
  EXPECT_NEAR(f.at<float>(300, 700), 0.3, 0.03);
}

// Road at level 30 with σ = 0.1 and, in the right half, SGM-like wrong-winner patches: 9×9 px
// blocks 0.8 above the road every 48 px (about 3.5 % of the pixels). The median-based noise
// barely notices them; the 0.999 quantile (LocalReliefSpikes) reports their height there and
// the Gaussian tail (≈ 3.3 σ = 0.33) on the clean left half.
TEST(ReliefNoise, Spikes) {
  cv::Mat value(480, 768, CV_32F), valid(value.size(), CV_8U, cv::Scalar(255));
  std::mt19937 rng(5);
  std::normal_distribution<float> n(0.f, 1.f);
  for (int v = 0; v < value.rows; ++v)
    for (int u = 0; u < value.cols; ++u) {
      const bool patch = u >= 384 && u % 48 < 9 && v % 48 < 9;
      value.at<float>(v, u) = static_cast<float>(30.0 + (patch ? 0.8 : 0.0) + 0.1 * n(rng));
    }
  const cv::Mat noise = LocalReliefNoise(value, valid, 30.0, 96, 0.05, 40.0);
  const cv::Mat spikes = LocalReliefSpikes(value, valid, 30.0, 96, 0.05, 40.0, 0.999);
  EXPECT_NEAR(noise.at<float>(240, 100), 0.1, 0.01);
  EXPECT_NEAR(noise.at<float>(240, 650), 0.1, 0.02);    // the median hardly moves
  EXPECT_NEAR(spikes.at<float>(240, 100), 0.32, 0.06);  // clean: the Gaussian tail
  EXPECT_GT(spikes.at<float>(240, 650), 0.8);           // the patches' height and their noise
  EXPECT_LT(spikes.at<float>(240, 650), 1.2);
  // The default quantile is the median path, unchanged.
  const cv::Mat median = LocalReliefNoise(value, valid, 30.0, 96, 0.05, 40.0, 0.5);
  EXPECT_EQ(cv::norm(median, noise, cv::NORM_INF), 0.0);
  EXPECT_THROW(LocalReliefSpikes(value, valid, 30.0, 96, 0.05, 40.0, 1.0), std::invalid_argument);
  EXPECT_THROW(LocalReliefSpikes(value, valid, 30.0, 96, 0.05, 40.0, 0.0), std::invalid_argument);
}

TEST(ReliefNoise, BadInput) {
  const cv::Mat value(64, 64, CV_32F, cv::Scalar(1)), valid(64, 64, CV_8U, cv::Scalar(255));
  EXPECT_THROW(LocalReliefNoise(value, valid, 0, 2, 0.1), std::invalid_argument);
  EXPECT_THROW(LocalReliefNoise(value, valid, 0, 16, 0), std::invalid_argument);
  EXPECT_THROW(LocalReliefNoise(cv::Mat(64, 64, CV_8U), valid, 0, 16, 0.1), std::invalid_argument);
  EXPECT_THROW(LocalReliefNoise(value, cv::Mat(32, 32, CV_8U), 0, 16, 0.1), std::invalid_argument);
  // No sample above the level anywhere: the floor.
  EXPECT_FLOAT_EQ(LocalReliefNoise(value, valid, 2.0, 16, 0.1).at<float>(10, 10), 0.1f);
}

// The spread below the level equals LocalReliefNoise of the mirrored image exactly (it replaced a
// negated copy of the frame in TwoSidedReliefNoise): a skewed relief at an awkward size, so the
// two sides differ and the comparison can fail.
TEST(ReliefNoise, BelowEqualsMirrored) {
  cv::Mat value(419, 631, CV_32F), valid(value.size(), CV_8U);
  std::mt19937 rng(11);
  std::normal_distribution<float> n(0.f, 1.f);
  std::uniform_int_distribution<int> drop(0, 9);
  for (int v = 0; v < value.rows; ++v)
    for (int u = 0; u < value.cols; ++u) {
      const float e = n(rng);
      value.at<float>(v, u) = 30.0f + (e < 0 ? (u < 300 ? 0.4f : 0.1f) : 0.2f) * e;
      valid.at<uchar>(v, u) = drop(rng) == 0 ? 0 : 255;
    }
  const cv::Mat below = LocalReliefNoiseBelow(value, valid, 30.0, 48, 0.05, 40.0);
  const cv::Mat mirrored = LocalReliefNoise(-value, valid, -30.0, 48, 0.05, 40.0);
  ASSERT_EQ(below.size(), value.size());
  EXPECT_EQ(cv::norm(below, mirrored, cv::NORM_INF), 0.0);
  // And it measures the lower side: 0.4 on the left, 0.1 on the right.
  EXPECT_NEAR(below.at<float>(200, 100), 0.4, 0.04);
  EXPECT_NEAR(below.at<float>(200, 550), 0.1, 0.01);
}

}  // namespace
}  // namespace rs
