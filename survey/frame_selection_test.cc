#include "survey/frame_selection.h"

#include <gtest/gtest.h>

#include "formats/input_error.h"
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

TEST(FrameSelection, FolderNameSetsRangeRunsApart) {
  EXPECT_EQ(FrameSelection::Parse("all").FolderName(), "");
  EXPECT_EQ(FrameSelection::Parse("0:10").FolderName(), "frames-0-10");
  EXPECT_EQ(FrameSelection::Parse(":4").FolderName(), "frames-0-4");
  EXPECT_EQ(FrameSelection::Parse("5:").FolderName(), "frames-5-end");
}

TEST(FrameSelection, EmptySelectionIsAnInputErrorStatingTheRange) {
  FrameSelection::Parse("all").RequireSelects(48, "survey.json");
  FrameSelection::Parse("47:100").RequireSelects(48, "survey.json");  // frame 47 is selected
  FrameSelection::Parse(":1").RequireSelects(48, "survey.json");
  try {
    FrameSelection::Parse("100:200").RequireSelects(48, "survey.json");
    FAIL() << "no frame selected but no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "survey.json: --frames 100:200 selects no frame: the survey has 48 frames, ids 0 to 47 (--frames 0:48)");
  }
  EXPECT_THROW(FrameSelection::Parse("48:").RequireSelects(48, "survey.json"), InputError);
}

}  // namespace
}  // namespace rs
