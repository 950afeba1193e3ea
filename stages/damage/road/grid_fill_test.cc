#include "stages/damage/road/grid_fill.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace rs {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(GridFill, EmptyCellTakesTheMeanOfItsFilledNeighbours) {
  cv::Mat g = (cv::Mat_<float>(3, 3) << 1, 2, 3, 4, kNaN, 6, 7, 8, kNaN);
  FillEmptyCellsFromNeighbours(&g);
  EXPECT_FLOAT_EQ(g.at<float>(1, 1), (1 + 2 + 3 + 4 + 6 + 7 + 8) / 7.0f);  // from the pass's start values
  EXPECT_FLOAT_EQ(g.at<float>(2, 2), (6 + 8) / 2.0f);
  EXPECT_FLOAT_EQ(g.at<float>(0, 0), 1.0f);  // filled cells are kept
}

TEST(GridFill, FillsRingByRingUntilNothingIsEmpty) {
  cv::Mat g(5, 7, CV_32F, cv::Scalar(kNaN));
  g.at<float>(0, 0) = 5.0f;
  FillEmptyCellsFromNeighbours(&g);
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x) EXPECT_FLOAT_EQ(g.at<float>(y, x), 5.0f) << y << "," << x;
}

TEST(GridFill, GridWithoutAnyValueStaysEmpty) {
  cv::Mat g(4, 4, CV_32F, cv::Scalar(kNaN));
  FillEmptyCellsFromNeighbours(&g);
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x) EXPECT_TRUE(std::isnan(g.at<float>(y, x)));
}

// A kerb (120 mm) between a gently sloping road and the pavement separates them, also when one
// cell lies on the kerb's face; an empty band (an obstacle) separates too; the slope does not.
TEST(GridFill, SmoothRegionsAreSplitAtStepsAndEmptyBands) {
  cv::Mat g(6, 12, CV_32F);
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x) g.at<float>(y, x) = x < 3 ? 120.0f : -10.0f * x;  // road: 10 per cell
  g.at<float>(2, 3) = 60.0f;  // a sample on the kerb face: two steps of 60 and 90
  int n = 0;
  cv::Mat l = LabelSmoothRegions(g, 100.0f, &n);
  // Pavement, the road column beside the kerb (cut off by the two-cell rule), the road.
  EXPECT_EQ(n, 3);
  EXPECT_NE(l.at<int>(0, 0), l.at<int>(0, 11));
  EXPECT_NE(l.at<int>(0, 0), l.at<int>(5, 3));
  EXPECT_EQ(l.at<int>(5, 4), l.at<int>(0, 11));
  EXPECT_EQ(l.at<int>(2, 3), l.at<int>(1, 3));  // the face sample goes with the road column
  g.col(7).setTo(kNaN);
  l = LabelSmoothRegions(g, 100.0f, &n);
  EXPECT_EQ(n, 4);
  EXPECT_EQ(l.at<int>(0, 7), 0);
  EXPECT_NE(l.at<int>(0, 6), l.at<int>(0, 8));
}

}  // namespace
}  // namespace rs
