#include "stages/damage/segment/rect_merge.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

TEST(RectMerge, ChainOfOverlapsBecomesOneUnionAndDisjointStaysApart) {
  std::vector<cv::Rect> r{{0, 0, 10, 10}, {50, 50, 5, 5}, {8, 8, 10, 10}, {16, 0, 4, 10}};
  MergeOverlappingRects(&r);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0], cv::Rect(0, 0, 20, 18));  // (0,0)-(10,10) ∪ (8,8)-(18,18) ∪ (16,0)-(20,10)
  EXPECT_EQ(r[1], cv::Rect(50, 50, 5, 5));
}

TEST(RectMerge, TouchingEdgesDoNotMerge) {
  std::vector<cv::Rect> r{{0, 0, 10, 10}, {10, 0, 10, 10}};
  MergeOverlappingRects(&r);
  EXPECT_EQ(r.size(), 2u);
}

}  // namespace
}  // namespace rs
