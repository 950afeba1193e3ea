#include "stages/damage/noise/image_edges.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace rs {
namespace {

// Speckled asphalt (grey 100 ± 40 in 2-px grains) with a 40-px white line (200) and a soft dark
// bowl (−40 over 30 px, like a shaded pothole): only the line's edges are masked.
TEST(StrongEdgeMask, Nominal) {
  cv::Mat img(240, 400, CV_8U);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> grain(-40, 40);
  for (int v = 0; v < img.rows; v += 2)
    for (int u = 0; u < img.cols; u += 2) img(cv::Rect(u, v, 2, 2)).setTo(100 + grain(rng));
  cv::Mat f;
  img.convertTo(f, CV_32F);
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) {
      const double r = std::hypot(u - 300, v - 120);
      f.at<float>(v, u) -= static_cast<float>(40.0 * std::clamp((60.0 - r) / 30.0, 0.0, 1.0));
    }
  f.convertTo(img, CV_8U);
  img(cv::Rect(100, 0, 40, 240)).setTo(200);
  const cv::Mat m = StrongEdgeMask(img, 9.0, 6);
  ASSERT_EQ(m.type(), CV_8UC1);
  ASSERT_EQ(m.size(), img.size());
  EXPECT_EQ(m.at<uchar>(120, 100), 255);                          // left edge of the line
  EXPECT_EQ(m.at<uchar>(120, 139), 255);                          // right edge
  EXPECT_EQ(m.at<uchar>(120, 94), 255);                           // within the margin
  EXPECT_EQ(m.at<uchar>(120, 120), 0);                            // the uniform paint itself
  EXPECT_EQ(cv::countNonZero(m(cv::Rect(160, 0, 240, 240))), 0);  // texture and the bowl
  EXPECT_EQ(cv::countNonZero(m(cv::Rect(0, 0, 80, 240))), 0);
}

TEST(StrongEdgeMask, BadInput) {
  EXPECT_THROW(StrongEdgeMask(cv::Mat(), 9, 6), std::invalid_argument);
  EXPECT_THROW(StrongEdgeMask(cv::Mat(10, 10, CV_32F), 9, 6), std::invalid_argument);
  EXPECT_THROW(StrongEdgeMask(cv::Mat(10, 10, CV_8U), 0, 6), std::invalid_argument);
  EXPECT_THROW(StrongEdgeMask(cv::Mat(10, 10, CV_8U), 9, -1), std::invalid_argument);
}

}  // namespace
}  // namespace rs
