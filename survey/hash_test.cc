#include "survey/hash.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

namespace rs {
namespace {
namespace fs = std::filesystem;

class FingerprintTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("rs_hash_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    Write("left/000000.png", "aa");
    Write("right/000000.png", "bb");
    Write("timestamps.csv", "filename,t_ns\n");
  }
  void TearDown() override { fs::remove_all(root_); }
  void Write(const std::string& rel, const std::string& bytes) {
    fs::create_directories((root_ / rel).parent_path());
    std::ofstream(root_ / rel) << bytes;
  }
  // The output owns what a run writes at its top level (as the executor's exclusion says).
  static OutputExclusion Output(const fs::path& dir) {
    return {dir, [](const std::string& name) { return name == "work" || name == "manifest.json" || name[0] == '.'; }};
  }
  fs::path root_;
};

TEST_F(FingerprintTest, InputChangesChangeTheKey) {
  const std::string before = FingerprintPath(root_);
  Write("left/000001.png", "cc");
  EXPECT_NE(FingerprintPath(root_), before);
}

TEST_F(FingerprintTest, OutputBelowTheInputFolderIsLeftOut) {
  const auto out = Output(root_ / "out");
  const std::string before = FingerprintPath(root_, out);
  Write("out/work/ingest/0123/stage.json", "{}");
  Write("out/anything.tiff", "x");
  EXPECT_EQ(FingerprintPath(root_, out), before);
  EXPECT_NE(FingerprintPath(root_), before);  // without the exclusion the same files count
}

TEST_F(FingerprintTest, OutputThatIsTheInputFolderLeavesOutWhatItOwns) {
  // `"output": "."`: the output folder is the frames folder itself; given as a non-canonical path.
  const auto out = Output(root_ / "left" / "..");
  const std::string before = FingerprintPath(root_, out);
  Write("work/disparity/abcd/frames/000000/disparity.png", "d");
  Write("manifest.json", "{}");
  Write(".manifest.json.tmp-1", "{");
  EXPECT_EQ(FingerprintPath(root_, out), before);
  Write("left/000001.png", "cc");  // a new frame is still an input change
  EXPECT_NE(FingerprintPath(root_, out), before);
}

TEST_F(FingerprintTest, MissingPathHasItsOwnKey) {
  EXPECT_NE(FingerprintPath(root_ / "nothing"), FingerprintPath(root_));
  EXPECT_EQ(FingerprintPath(root_ / "nothing"), FingerprintPath(root_ / "nothing"));
}

TEST(Sha256, KnownDigests) {  // FIPS 180-4 examples; 55/56/64 bytes cross the padding's block edge
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(Sha256Hex(std::string(64, 'a')), "ffe054fe7ae0cb6dc65c3af9b61d5209f439851db43d0ba5997337df154668eb");
  EXPECT_EQ(Sha256Hex(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

}  // namespace
}  // namespace rs
