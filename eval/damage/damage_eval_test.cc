#include "eval/damage/damage_eval.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace rs {
namespace {

TEST(ComparePixels, Nominal) {
  cv::Mat p = cv::Mat::zeros(10, 10, CV_8U), t = cv::Mat::zeros(10, 10, CV_8U);
  p(cv::Rect(0, 0, 4, 5)).setTo(1);  // 20 px
  t(cv::Rect(0, 0, 4, 4)).setTo(9);  // 16 px, all inside p
  const PixelMetrics m = ComparePixels(p, t);
  EXPECT_EQ(m.tp, 16);
  EXPECT_EQ(m.fp, 4);
  EXPECT_EQ(m.fn, 0);
  EXPECT_DOUBLE_EQ(m.precision, 0.8);
  EXPECT_DOUBLE_EQ(m.recall, 1.0);
  EXPECT_DOUBLE_EQ(m.f1, 32.0 / 36.0);
  EXPECT_DOUBLE_EQ(m.iou, 0.8);
  EXPECT_THROW(ComparePixels(p, cv::Mat::zeros(5, 5, CV_8U)), std::invalid_argument);
}

TEST(MatchInstances, Nominal) {
  cv::Mat p = cv::Mat::zeros(50, 50, CV_16U), t = cv::Mat::zeros(50, 50, CV_16U);
  p(cv::Rect(0, 0, 10, 10)).setTo(1);
  p(cv::Rect(30, 30, 10, 10)).setTo(2);  // IoU 25/175 with truth 2: below 0.5
  t(cv::Rect(0, 0, 10, 9)).setTo(1);     // IoU 0.9
  t(cv::Rect(35, 35, 10, 10)).setTo(2);
  DamageInstance d;
  d.id = 1, d.area_m2 = 0.11, d.max_depth_m = 0.05, d.volume_m3 = 0.002;
  TruthInstance g;
  g.id = 1, g.area_m2 = 0.10, g.max_depth_m = 0.045, g.volume_m3 = 0.0025;
  const InstanceEvaluation e = MatchInstances(p, t, {d}, {g});
  ASSERT_EQ(e.matches.size(), 1u);
  EXPECT_NEAR(e.matches[0].iou, 0.9, 1e-12);
  EXPECT_NEAR(e.matches[0].area_error_m2, 0.01, 1e-12);
  EXPECT_NEAR(e.matches[0].max_depth_error_m, 0.005, 1e-12);
  EXPECT_NEAR(e.matches[0].volume_error_m3, -0.0005, 1e-12);
  EXPECT_EQ(e.false_positives, 1);
  EXPECT_EQ(e.false_negatives, 1);
  EXPECT_DOUBLE_EQ(e.f1, 0.5);
}

}  // namespace
}  // namespace rs
