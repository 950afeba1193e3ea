#include "stages/disparity/perspective_transform.h"

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
  EXPECT_NEAR(t.at<float>(50, 199), 8.0, 1e-4);                          // on the row minimum: delta
  EXPECT_NEAR(t.at<float>(50, 0), 8.0 - (road.At(0, 50) - road.At(199, 50)), 1e-4);
}

TEST(PerspectiveTransform, KappaRowMismatch) {
  cv::Mat img(10, 10, CV_8U, cv::Scalar(0));
  EXPECT_THROW(WarpTarget(img, std::vector<double>(9, 0.0)), std::invalid_argument);
}

}  // namespace
}  // namespace rs
