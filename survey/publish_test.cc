#include "survey/publish.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <iterator>

#include "survey/atomic_file.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("rs_publish_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Every name under `dir`, relative.
std::vector<std::string> Names(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::recursive_directory_iterator(dir)) names.push_back(fs::relative(e.path(), dir).string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(Publish, TemporaryNames) {
  EXPECT_TRUE(IsTemporaryName(TemporarySibling("/x/ingest.json").filename().string()));
  EXPECT_TRUE(IsTemporaryName(".000007.tmp-1234-5"));
  EXPECT_FALSE(IsTemporaryName("000007"));
  EXPECT_FALSE(IsTemporaryName("ingest.json"));
  EXPECT_FALSE(IsTemporaryName(".tmp-1-2"));
  EXPECT_FALSE(IsTemporaryName("notes.tmp-draft"));
}

// Publishing the same file again (every re-run) leaves one name: rename(2) onto another link to
// the same file is a no-op that used to leave the temporary link beside it.
TEST(Publish, RepublishingLeavesNoTemporary) {
  const fs::path dir = FreshDir("file");
  WriteFileAtomic(dir / "work" / "a.json", "{}\n");
  for (int i = 0; i < 3; ++i) PublishFile(dir / "work" / "a.json", dir / "a.json");
  EXPECT_EQ(Names(dir), (std::vector<std::string>{"a.json", "work", "work/a.json"}));
  EXPECT_TRUE(fs::equivalent(dir / "a.json", dir / "work" / "a.json"));
  // A new result replaces the published one.
  WriteFileAtomic(dir / "work" / "b.json", "[1]\n");
  PublishFile(dir / "work" / "b.json", dir / "a.json");
  EXPECT_EQ(Slurp(dir / "a.json"), "[1]\n");
  EXPECT_EQ(Names(dir), (std::vector<std::string>{"a.json", "work", "work/a.json", "work/b.json"}));
}

// A folder is published without the temporaries inside it and replaces the old one whole.
TEST(Publish, FolderSkipsTemporaries) {
  const fs::path dir = FreshDir("folder");
  const fs::path frames = dir / "work" / "frames";
  WriteFileAtomic(frames / "000000" / "d.png", "zero");
  WriteFileAtomic(frames / ".000001.tmp-99-3" / "d.png", "half");
  PublishFile(frames, dir / "disparity");
  EXPECT_EQ(Names(dir / "disparity"), (std::vector<std::string>{"000000", "000000/d.png"}));
  WriteFileAtomic(frames / "000001" / "d.png", "one");
  PublishFile(frames, dir / "disparity");
  EXPECT_EQ(Names(dir / "disparity"), (std::vector<std::string>{"000000", "000000/d.png", "000001", "000001/d.png"}));
  EXPECT_EQ(Slurp(dir / "disparity" / "000001" / "d.png"), "one");
  // The only temporary left is the one in the source, which a publish does not touch.
  for (const auto& name : Names(dir))
    if (name.find(".tmp-") != std::string::npos) EXPECT_EQ(name.rfind("work/frames/.000001.tmp-99-3", 0), 0u) << name;
}

TEST(Publish, RemovesOrphansOfKilledRuns) {
  const fs::path dir = FreshDir("orphans");
  WriteFileAtomic(dir / "work" / "disparity" / "abc" / "frames" / "000000" / "d.png", "ok");
  WriteFileAtomic(dir / "work" / "disparity" / "abc" / "frames" / ".000001.tmp-7-1" / "d.png", "half");
  WriteFileAtomic(dir / ".ingest.json.tmp-7-2", "{");
  WriteFileAtomic(dir / "work" / "slam" / "def.rerun" / "trajectory.tum", "1");
  WriteFileAtomic(dir / "work" / "slam" / "def.old" / "trajectory.tum", "1");
  WriteFileAtomic(dir / "notes.old", "the user's file");  // not in work/<stage>/: kept
  EXPECT_EQ(RemoveOrphanTemporaries(dir), 4);
  EXPECT_EQ(Names(dir), (std::vector<std::string>{"notes.old", "work", "work/disparity", "work/disparity/abc",
                                                  "work/disparity/abc/frames", "work/disparity/abc/frames/000000",
                                                  "work/disparity/abc/frames/000000/d.png", "work/slam"}));
  EXPECT_EQ(RemoveOrphanTemporaries(dir), 0);
}

}  // namespace
}  // namespace rs
