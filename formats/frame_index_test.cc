#include "formats/frame_index.h"

#include <gtest/gtest.h>

#include <sstream>

#include "formats/input_error.h"

namespace rs {
namespace {

TEST(FrameIndex, Nominal) {
  std::vector<FrameRecord> frames = {{FrameId{0}, 1000, "/a/left/0.png", "/a/right/0.png"},
                                     {FrameId{1}, 2000, "/a,b/left/\"q\".png", "/a,b/right/1.png"}};
  std::stringstream ss;
  WriteFrameIndex(ss, frames);
  const auto back = ReadFrameIndex(ss, "frames.csv");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].id.value, 1);
  EXPECT_EQ(back[1].t_ns, 2000);
  EXPECT_EQ(back[1].left, frames[1].left);
  EXPECT_EQ(back[1].right, frames[1].right);
}

TEST(FrameIndex, BadRowNamesLine) {
  std::stringstream ss("frame_id,t_ns,left,right\n0,10,a,b\n1,x,a,b\n");
  try {
    ReadFrameIndex(ss, "frames.csv");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_NE(std::string(e.what()).find("t_ns 'x'"), std::string::npos);
  }
}

TEST(FrameIndex, MissingHeader) {
  std::stringstream ss("0,10,a,b\n");
  EXPECT_THROW(ReadFrameIndex(ss, "frames.csv"), InputError);
}

}  // namespace
}  // namespace rs
