// Publishing never exposes a temporary: re-runs leave no temporary link beside the published
// names, and the half-written frame folders of a run killed mid-frame are removed by the next
// run instead of being published (disparity/.000007.tmp-.../disparity.png).
#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

using FaultPublish = FaultTest;

// Every re-run used to add .ingest.json.tmp-*, .trajectory.tum.tmp-* and .keyframes.tum.tmp-*
// (a hard link renamed onto another link to the same file is a no-op that keeps the source).
TEST_F(FaultPublish, RerunsLeaveNoTemporaries) {
  const fs::path out = Output("reruns");
  const auto clean = CleanRunFiles(out);
  for (int i = 0; i < 3; ++i) {
    const auto r = Run(out);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
  EXPECT_EQ(Differences(clean, PublishedFiles(out)), std::vector<std::string>{});
}

// kill -9 while a frame is being written (its temporary folder exists), then a resume.
TEST_F(FaultPublish, KillMidFrameThenResume) {
  const fs::path out = Output("kill_mid_frame");
  const auto clean = CleanRunFiles(out);
  // A first complete run, so that the killed run's stages publish over existing outputs too.
  ASSERT_EQ(Run(out).exit_code, 0);
  ASSERT_EQ(Run(out, "--rerun-from disparity").exit_code, 0);
  {
    BackgroundRun run(RunArgs(out, "--rerun-from disparity"));
    const auto work = out / "work";
    ASSERT_TRUE(WaitUntil([&] { return HasTemporaryName(work); })) << "no frame was ever being written";
    ASSERT_TRUE(run.Kill9()) << "the run finished before the kill";
  }
  ASSERT_FALSE(TemporaryNames(out).empty()) << "the kill left nothing half-written: the test proves nothing";
  const auto r = Run(out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
  EXPECT_EQ(Differences(clean, PublishedFiles(out)), std::vector<std::string>{});
}

// kill -9 of a first run (nothing cached yet) mid-frame, then a resume.
TEST_F(FaultPublish, KillFirstRunMidFrameThenResume) {
  const fs::path out = Output("kill_first_run");
  const auto clean = CleanRunFiles(out);
  {
    BackgroundRun run(RunArgs(out));
    ASSERT_TRUE(WaitUntil([&] {
      for (const auto& name : TemporaryNames(out))
        if (name.find("frames/.") != std::string::npos && name.find("disparity") != std::string::npos) return true;
      return false;
    })) << "no disparity frame was ever being written";
    ASSERT_TRUE(run.Kill9()) << "the run finished before the kill";
  }
  const auto r = Run(out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
  EXPECT_EQ(Differences(clean, PublishedFiles(out)), std::vector<std::string>{});
}

}  // namespace
}  // namespace rs::test
