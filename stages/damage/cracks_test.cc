#include "stages/damage/cracks.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace rs {
namespace {

cv::Mat Asphalt(unsigned seed) {
  cv::Mat noise(480, 640, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, 12);
  cv::GaussianBlur(noise, noise, {0, 0}, 1.2);
  cv::Mat img;
  noise.convertTo(img, CV_8U, 1.0, 128);
  return img;
}

// A dark 5 px wide line, 412 px long, at 2 mm per pixel: length 0.825 m ± 10 %,
// mean width 10 mm ± 3 mm (±1.5 px), FHWA moderate needs 6–19 mm.
TEST(DetectCracks, Nominal) {
  cv::Mat img = Asphalt(1);
  cv::line(img, {100, 200}, {500, 300}, cv::Scalar(60), 5, cv::LINE_8);
  const cv::Mat px(img.size(), CV_32F, cv::Scalar(0.002));
  const CrackDetection c = DetectCracks(img, cv::Mat(), cv::Mat(), px, CrackOptions());
  ASSERT_EQ(c.instances.size(), 1u);
  const DamageInstance& d = c.instances[0];
  const double true_len = std::hypot(400.0, 100.0) * 0.002;
  EXPECT_EQ(d.type, DamageType::kCrack);
  EXPECT_NEAR(d.length_m, true_len, 0.10 * true_len);
  EXPECT_NEAR(d.mean_width_m, 0.010, 0.003);
  EXPECT_GE(d.max_width_m, d.mean_width_m);
  EXPECT_GT(d.confidence, 0.5);
}

TEST(DetectCracks, TextureOnly) {
  const cv::Mat img = Asphalt(2);
  const cv::Mat px(img.size(), CV_32F, cv::Scalar(0.002));
  EXPECT_TRUE(DetectCracks(img, cv::Mat(), cv::Mat(), px, CrackOptions()).instances.empty());
}

TEST(DetectCracks, ExcludedAndOffRoad) {
  cv::Mat img = Asphalt(3);
  cv::line(img, {100, 200}, {500, 300}, cv::Scalar(60), 5, cv::LINE_8);
  cv::Mat road = cv::Mat::zeros(img.size(), CV_8U);
  road(cv::Rect(0, 0, 640, 100)).setTo(255);  // the crack is off the road
  EXPECT_TRUE(DetectCracks(img, road, cv::Mat(), cv::Mat(), CrackOptions()).instances.empty());
  EXPECT_THROW(DetectCracks(cv::Mat(10, 10, CV_32F), cv::Mat(), cv::Mat(), cv::Mat(), CrackOptions()),
               std::invalid_argument);
}

}  // namespace
}  // namespace rs
