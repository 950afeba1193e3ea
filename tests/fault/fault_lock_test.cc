// One run per output folder: a second run beside a running one exits 1 naming the holder (it
// used to compute too and die with "cannot copy: File exists", leaving out/.damage.tmp-*), and a
// lock left by a killed run is taken over with a note.
#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

using FaultLock = FaultTest;

TEST_F(FaultLock, SecondConcurrentRunExitsOneNamingTheHolder) {
  const fs::path out = Output("concurrent");
  const auto clean = CleanRunFiles(out);
  BackgroundRun first(RunArgs(out));
  // The first run has started writing into the folder (the lock comes first, the manifest after ingest).
  ASSERT_TRUE(WaitUntil([&] { return fs::exists(out / ".roadsurvey.lock") || fs::exists(out / "manifest.json"); }));
  const auto second = Run(out);
  const bool first_still_running = ::kill(first.pid(), 0) == 0;
  EXPECT_EQ(second.exit_code, 1) << second.output;
  EXPECT_NE(second.output.find("in use by another run"), std::string::npos) << second.output;
  EXPECT_NE(second.output.find("PID " + std::to_string(first.pid())), std::string::npos) << second.output;
  EXPECT_EQ(first.Wait(), 0);
  EXPECT_TRUE(first_still_running) << "the first run ended before the second started: the test proves nothing";
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
  EXPECT_EQ(Differences(clean, PublishedFiles(out)), std::vector<std::string>{});
  EXPECT_FALSE(fs::exists(out / ".roadsurvey.lock")) << "a finished run releases the folder";
}

TEST_F(FaultLock, StaleLockOfAKilledRunIsTakenOver) {
  const fs::path out = Output("stale");
  const auto clean = CleanRunFiles(out);
  pid_t killed_pid = 0;
  {
    BackgroundRun run(RunArgs(out));
    killed_pid = run.pid();
    ASSERT_TRUE(WaitUntil([&] { return fs::exists(out / "manifest.json"); }));
    ASSERT_TRUE(run.Kill9()) << "the run finished before the kill";
  }
  const auto r = Run(out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("PID " + std::to_string(killed_pid)), std::string::npos)
      << "the note must name the killed run:\n"
      << r.output;
  EXPECT_NE(r.output.find("taking it over"), std::string::npos) << r.output;
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
  EXPECT_EQ(Differences(clean, PublishedFiles(out)), std::vector<std::string>{});
}

}  // namespace
}  // namespace rs::test
