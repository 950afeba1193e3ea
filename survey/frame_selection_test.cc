#include "survey/frame_selection.h"

#include <gtest/gtest.h>

#include "survey/options.h"

namespace rs {
namespace {

TEST(FrameSelection, Nominal) {
  EXPECT_TRUE(FrameSelection::Parse("all").All());
  const auto s = FrameSelection::Parse("10:20");
  EXPECT_TRUE(s.Contains(10));
  EXPECT_FALSE(s.Contains(20));
  EXPECT_EQ(s.ToString(), "10:20");
  EXPECT_EQ(FrameSelection::Parse("5:").ToString(), "5:");
  EXPECT_EQ(FrameSelection::Parse(":5").ToString(), "0:5");
}

TEST(FrameSelection, Malformed) {
  EXPECT_THROW(FrameSelection::Parse("5"), OptionError);
  EXPECT_THROW(FrameSelection::Parse("a:b"), OptionError);
  EXPECT_THROW(FrameSelection::Parse("7:3"), OptionError);
  EXPECT_THROW(FrameSelection::Parse("-1:3"), OptionError);
}

}  // namespace
}  // namespace rs
