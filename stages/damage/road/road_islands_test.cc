#include "stages/damage/road/road_islands.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <limits>
#include <stdexcept>

namespace rs {
namespace {

// A 301×201 road (odd sizes: the last row and column form no 2×2 block) with an obstacle
// frame (rows 40-99, columns 60-139, 10 px wide) enclosing a 40×60 patch of road.
cv::Mat RoadWithEnclosedPatch() {
  cv::Mat road(201, 301, CV_8U, cv::Scalar(255));
  cv::rectangle(road, cv::Rect(60, 40, 80, 60), cv::Scalar(0), 10);  // 10-px band centred on the outline
  return road;
}

TEST(RoadIslandMask, Nominal) {
  const cv::Mat road = RoadWithEnclosedPatch();
  // 1 cm² per pixel: the enclosed patch (70×50 px inside the band's inner edge) is 0.35 m²,
  // the road outside it ~5.3 m².
  const cv::Mat area(road.size(), CV_32F, cv::Scalar(1e-4f));
  const cv::Mat islands = RoadIslandMask(road, area, 1.0);
  const cv::Rect inner(70, 50, 60, 40);
  EXPECT_EQ(cv::countNonZero(islands(inner)), inner.area());  // the whole patch
  EXPECT_EQ(cv::countNonZero(islands & (road == 0)), 0);      // never a non-road pixel
  cv::Mat outside = road.clone();
  cv::rectangle(outside, cv::Rect(55, 35, 90, 70), cv::Scalar(0), cv::FILLED);
  EXPECT_EQ(cv::countNonZero(islands & outside), 0);  // the road around is one large region
}

TEST(RoadIslandMask, AreaIsOnTheRoadNotInPixels) {
  const cv::Mat road = RoadWithEnclosedPatch();
  // 1 dm² per pixel: the same patch is 35 m² of road, not an island.
  const cv::Mat area(road.size(), CV_32F, cv::Scalar(1e-2f));
  EXPECT_EQ(cv::countNonZero(RoadIslandMask(road, area, 1.0)), 0);
  // NaN (off-road, above the horizon) pixels add nothing: with the upper rows NaN and the rest
  // at 1 cm², the patch is an island and the road below it is not.
  cv::Mat partly(road.size(), CV_32F, cv::Scalar(1e-4f));
  partly.rowRange(0, 30).setTo(std::numeric_limits<float>::quiet_NaN());
  const cv::Mat islands = RoadIslandMask(road, partly, 1.0);
  EXPECT_EQ(cv::countNonZero(islands(cv::Rect(70, 50, 60, 40))), 2400);
  EXPECT_EQ(cv::countNonZero(islands.rowRange(110, 200)), 0);
}

TEST(RoadIslandMask, OnePixelBridgeDoesNotJoin) {
  cv::Mat road = RoadWithEnclosedPatch();
  road(cv::Rect(99, 35, 1, 20)).setTo(255);  // a one-pixel-wide path of road through the band
  const cv::Mat area(road.size(), CV_32F, cv::Scalar(1e-4f));
  const cv::Mat islands = RoadIslandMask(road, area, 1.0);
  EXPECT_EQ(cv::countNonZero(islands(cv::Rect(70, 50, 60, 40))), 2400);
  // A two-block-wide opening joins it to the road.
  road(cv::Rect(96, 35, 8, 20)).setTo(255);
  EXPECT_EQ(cv::countNonZero(RoadIslandMask(road, area, 1.0)), 0);
}

TEST(RoadIslandMask, OffAndBadInput) {
  const cv::Mat road = RoadWithEnclosedPatch();
  const cv::Mat area(road.size(), CV_32F, cv::Scalar(1e-4f));
  EXPECT_EQ(cv::countNonZero(RoadIslandMask(road, area, 0.0)), 0);
  EXPECT_THROW(RoadIslandMask(road, cv::Mat(10, 10, CV_32F), 1.0), std::invalid_argument);
  EXPECT_THROW(RoadIslandMask(cv::Mat(road.size(), CV_16U), area, 1.0), std::invalid_argument);
}

}  // namespace
}  // namespace rs
