#include "stages/damage/grid_fill.h"

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

}  // namespace
}  // namespace rs
