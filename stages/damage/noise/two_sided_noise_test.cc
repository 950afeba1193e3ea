#include "stages/damage/noise/two_sided_noise.h"

#include "stages/damage/noise/relief_noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

namespace rs {
namespace {

// Road at level 30 with σ = 0.1, a 0.5-deep bowl (damage: the tail below the level) and a kerb-like
// rise of up to 2.0 over one noise cell (96 columns) (structure the road model did not follow: the tail above).
// The one-sided noise counts the rise; the two-sided one must not, and must leave the plain road
// and the bowl's cell as they were.
TEST(TwoSidedReliefNoise, Nominal) {
  cv::Mat value(480, 768, CV_32F), valid(value.size(), CV_8U, cv::Scalar(255));
  std::mt19937 rng(5);
  std::normal_distribution<float> n(0.f, 1.f);
  for (int v = 0; v < value.rows; ++v)
    for (int u = 0; u < value.cols; ++u) {
      const double bowl = std::hypot(u - 200, v - 240) < 50 ? 0.5 : 0.0;
      const double rise = u >= 576 && u < 672 ? 2.0 * (u - 576) / 96.0 : 0.0;
      value.at<float>(v, u) = static_cast<float>(30.0 - bowl + rise + 0.1 * n(rng));
    }
  const double floor_sigma = 0.05, max_ratio = 40.0;
  const cv::Mat up = LocalReliefNoise(value, valid, 30.0, 96, floor_sigma, max_ratio);
  const cv::Mat s = TwoSidedReliefNoise(up, value, valid, 30.0, 96, floor_sigma, max_ratio);
  ASSERT_EQ(s.type(), CV_32FC1);
  ASSERT_EQ(s.size(), value.size());
  EXPECT_GT(up.at<float>(240, 620), 0.4);                    // the rise counted as noise one-sided
  EXPECT_LE(s.at<float>(240, 620), 2 * 0.1 * 1.1);           // two-sided: at most twice the spread below
  EXPECT_EQ(s.at<float>(240, 380), up.at<float>(240, 380));  // plain road: unchanged
  EXPECT_NEAR(s.at<float>(240, 380), 0.1, 0.01);
  EXPECT_EQ(s.at<float>(240, 200), up.at<float>(240, 200));  // the bowl: only the tail below grows
  EXPECT_NEAR(s.at<float>(240, 200), 0.1, 0.01);
  double lo = 0;
  cv::minMaxLoc(s, &lo);
  EXPECT_GE(lo, floor_sigma);
}

// A pothole in the same cell as the rise (car: beside the verge): its walls fill the spread below
// the level, so the cap (twice that spread) no longer holds the rise back, and a well-measured
// pothole there failed the noise rule. Given as a found instance, its own pixels are left out of
// the spread below on that instance; elsewhere the map is unchanged.
TEST(TwoSidedReliefNoise, OwnWallsAreNotNoiseBelow) {
  cv::Mat value(480, 768, CV_32F), valid(value.size(), CV_8U, cv::Scalar(255));
  cv::Mat instances(value.size(), CV_16U, cv::Scalar(0));
  std::mt19937 rng(7);
  std::normal_distribution<float> n(0.f, 1.f);
  for (int v = 0; v < value.rows; ++v)
    for (int u = 0; u < value.cols; ++u) {
      const double r = std::hypot(u - 620, v - 240);
      const double bowl = r < 46 ? 2.0 * (1 - r * r / (46.0 * 46.0)) : 0.0;
      const double rise = u >= 576 && u < 672 ? 2.0 * (u - 576) / 96.0 : 0.0;
      value.at<float>(v, u) = static_cast<float>(30.0 - bowl + rise + 0.1 * n(rng));
      if (r < 52) instances.at<uint16_t>(v, u) = 1;  // the segmentation's outline with its halo
    }
  const double floor_sigma = 0.05, max_ratio = 40.0;
  const cv::Mat up = LocalReliefNoise(value, valid, 30.0, 96, floor_sigma, max_ratio);
  const cv::Mat with_bowl = TwoSidedReliefNoise(up, value, valid, 30.0, 96, floor_sigma, max_ratio);
  const cv::Mat s = TwoSidedReliefNoise(up, value, valid, 30.0, 96, floor_sigma, max_ratio, 2.0, instances);
  EXPECT_GT(up.at<float>(240, 620), 0.4);         // the rise, one-sided
  EXPECT_GT(with_bowl.at<float>(240, 620), 0.3);  // the bowl's walls lifted the cap
  EXPECT_LE(s.at<float>(240, 620), 2 * 0.1 * 1.1);
  EXPECT_EQ(s.at<float>(300, 660), with_bowl.at<float>(300, 660));  // off the instance: unchanged
  EXPECT_NEAR(s.at<float>(240, 200), 0.1, 0.01);                    // plain road
  EXPECT_EQ(s.at<float>(240, 200), up.at<float>(240, 200));
  EXPECT_THROW(TwoSidedReliefNoise(up, value, valid, 30.0, 96, floor_sigma, max_ratio, 2.0, cv::Mat(10, 10, CV_16U)),
               std::invalid_argument);
  EXPECT_THROW(TwoSidedReliefNoise(up, value, valid, 30.0, 96, floor_sigma, max_ratio, 2.0,
                                   cv::Mat(value.size(), CV_8U, cv::Scalar(0))),
               std::invalid_argument);
}

TEST(TwoSidedReliefNoise, BadInput) {
  const cv::Mat value(96, 96, CV_32F, cv::Scalar(30)), valid(value.size(), CV_8U, cv::Scalar(255));
  EXPECT_THROW(TwoSidedReliefNoise(cv::Mat(10, 10, CV_32F), value, valid, 30, 96, 0.05, 40), std::invalid_argument);
  EXPECT_THROW(TwoSidedReliefNoise(cv::Mat(value.size(), CV_8U), value, valid, 30, 96, 0.05, 40),
               std::invalid_argument);
  const cv::Mat up(value.size(), CV_32F, cv::Scalar(0.1));
  EXPECT_THROW(TwoSidedReliefNoise(up, value, valid, 30, 96, 0.05, 40, 0.5), std::invalid_argument);
  EXPECT_THROW(TwoSidedReliefNoise(up, value, valid, 30, 2, 0.05, 40), std::invalid_argument);
}

}  // namespace
}  // namespace rs
