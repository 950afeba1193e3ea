// Tolerance scoring on synthetic masks whose counts follow exactly from their geometry.
#include "eval/damage/crack_score.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace rs {
namespace {

cv::Mat Row(int v, int u0, int u1) {
  cv::Mat m = cv::Mat::zeros(40, 60, CV_8U);
  m(cv::Range(v, v + 1), cv::Range(u0, u1)).setTo(255);
  return m;
}

TEST(ScoreCrackPixels, ShiftWithinAndBeyondTolerance) {
  const cv::Mat truth = Row(20, 10, 50);  // 40 px
  const TolerantPixelScore two = ScoreCrackPixels(Row(22, 10, 50), truth, 2.0);
  EXPECT_EQ(two.predicted, 40);
  EXPECT_EQ(two.predicted_near, 40);
  EXPECT_EQ(two.truth_near, 40);
  EXPECT_DOUBLE_EQ(two.F1(), 1.0);
  const TolerantPixelScore three = ScoreCrackPixels(Row(23, 10, 50), truth, 2.0);
  EXPECT_EQ(three.predicted_near, 0);
  EXPECT_EQ(three.truth_near, 0);
  EXPECT_DOUBLE_EQ(three.F1(), 0.0);
}

// Prediction covers u 30..69 of a truth at u 10..49 on the same row, tolerance 2: predicted
// pixels 30..51 are near (22 of 40), true pixels 28..49 (22 of 40).
TEST(ScoreCrackPixels, PartialOverlapAlongTheLine) {
  cv::Mat truth = cv::Mat::zeros(40, 80, CV_8U), pred = truth.clone();
  truth(cv::Range(5, 6), cv::Range(10, 50)).setTo(1);
  pred(cv::Range(5, 6), cv::Range(30, 70)).setTo(1);
  const TolerantPixelScore s = ScoreCrackPixels(pred, truth, 2.0);
  EXPECT_EQ(s.predicted_near, 22);
  EXPECT_EQ(s.truth_near, 22);
  EXPECT_DOUBLE_EQ(s.Precision(), 22.0 / 40);
  EXPECT_DOUBLE_EQ(s.Recall(), 22.0 / 40);
  // Exact overlap only (tolerance 0): 20 pixels in common.
  const TolerantPixelScore exact = ScoreCrackPixels(pred, truth, 0.0);
  EXPECT_EQ(exact.predicted_near, 20);
  EXPECT_EQ(exact.truth_near, 20);
}

// A diagonal neighbour at distance √8 (2 px each way) is within 2√2 but not within 2.8.
TEST(ScoreCrackPixels, EuclideanDistance) {
  cv::Mat truth = cv::Mat::zeros(10, 10, CV_8U), pred = truth.clone();
  truth.at<uchar>(3, 3) = 255;
  pred.at<uchar>(5, 5) = 255;
  EXPECT_EQ(ScoreCrackPixels(pred, truth, std::sqrt(8.0)).predicted_near, 1);
  EXPECT_EQ(ScoreCrackPixels(pred, truth, 2.8).predicted_near, 0);
}

TEST(ScoreCrackPixels, EmptyMasksAndPooling) {
  const cv::Mat none = cv::Mat::zeros(40, 60, CV_8U), truth = Row(20, 10, 50);
  const TolerantPixelScore missed = ScoreCrackPixels(none, truth, 2.0);
  EXPECT_EQ(missed.predicted, 0);
  EXPECT_DOUBLE_EQ(missed.Precision(), 0.0);
  EXPECT_DOUBLE_EQ(missed.Recall(), 0.0);
  const TolerantPixelScore false_only = ScoreCrackPixels(truth, none, 2.0);
  EXPECT_DOUBLE_EQ(false_only.Precision(), 0.0);
  EXPECT_DOUBLE_EQ(false_only.Recall(), 1.0);
  EXPECT_DOUBLE_EQ(ScoreCrackPixels(none, none, 2.0).F1(), 1.0);
  // Pooled: 40 predicted, 0 near; 40 true, 0 near; plus a perfect image.
  TolerantPixelScore pooled = false_only;
  pooled += missed;
  pooled += ScoreCrackPixels(truth, truth, 2.0);
  EXPECT_EQ(pooled.predicted, 80);
  EXPECT_EQ(pooled.predicted_near, 40);
  EXPECT_EQ(pooled.truth, 80);
  EXPECT_EQ(pooled.truth_near, 40);
  EXPECT_DOUBLE_EQ(pooled.F1(), 0.5);
  EXPECT_THROW(ScoreCrackPixels(none, cv::Mat::zeros(41, 60, CV_8U), 2.0), std::invalid_argument);
  EXPECT_THROW(ScoreCrackPixels(none, none, -1.0), std::invalid_argument);
}

}  // namespace
}  // namespace rs
