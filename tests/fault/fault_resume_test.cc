// kill -9 at seeded random moments of the README demo (`roadsurvey simulate demo`, then
// `roadsurvey run demo/survey.json`), each followed by a resume: every published file equals
// an uninterrupted run's byte for byte, no temporary name is left anywhere under the output,
// and no frame (or whole stage) that had finished before the kill is computed again.
//
// ROADSURVEY_FAULT_SEED and ROADSURVEY_FAULT_KILLS change the schedule (default: seed 28, 20 kills).
#include <algorithm>
#include <random>
#include <set>

#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

/// What the cache held at one moment: finished frames per per-frame stage, finished stages.
struct CacheState {
  std::map<std::string, int> finished_frames;
  std::set<std::string> finished_stages;
};

CacheState ReadCacheState(const fs::path& out) {
  CacheState s;
  std::error_code ec;
  for (const auto& stage : fs::directory_iterator(out / "work", ec)) {
    if (!stage.is_directory()) continue;
    const std::string name = stage.path().filename().string();
    for (const auto& key : fs::directory_iterator(stage.path(), ec)) {
      if (fs::exists(key.path() / "stage.json")) s.finished_stages.insert(name);
      for (const auto& frame : fs::directory_iterator(key.path() / "frames", ec))
        s.finished_frames[name] += frame.path().filename().string()[0] != '.';
    }
  }
  return s;
}

class KillResume : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("rs_fault_resume_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    RemoveAtExit(root_);
    fs::create_directories(root_);
    const auto r = RunProgram("simulate " + (root_ / "demo").string() + " --progress quiet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  // The surface's mesh is left out: its decimation would double each of the 20 runs, and its files
  // take the same write and publish path as the rasters, which are in.
  static std::string RunArgs(const fs::path& out) {
    return "run " + (root_ / "demo" / "survey.json").string() + " --output " + out.string() +
           " --progress quiet --surface.mesh false";
  }
  static fs::path root_;
};
fs::path KillResume::root_;

TEST_F(KillResume, SeededKillsThenResumeGiveTheUninterruptedOutputs) {
  const fs::path out = root_ / "out";
  const auto t0 = std::chrono::steady_clock::now();
  const auto clean = RunProgram(RunArgs(out));
  const double clean_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(clean.exit_code, 0) << clean.output;
  const auto reference = PublishedFiles(out);
  ASSERT_GT(reference.size(), 10u);

  const unsigned seed = static_cast<unsigned>(EnvInt("ROADSURVEY_FAULT_SEED", 28));
  const int kills = EnvInt("ROADSURVEY_FAULT_KILLS", 20);
  std::mt19937 rng(seed);
  // Moments spread over the whole run, start-up and the final publish included. A run that ended
  // before its kill shows the runs to be shorter now than the clean one was (which may have
  // shared the cores with other tests): the window shrinks to that moment.
  double run_s = clean_s;
  int interrupted = 0;
  for (int i = 0; i < kills; ++i) {
    SCOPED_TRACE(::testing::Message() << "kill " << i << " of seed " << seed);
    fs::remove_all(out);
    const double at_s = std::uniform_real_distribution<double>(0.02 * run_s, run_s)(rng);
    BackgroundRun run(RunArgs(out));
    std::this_thread::sleep_for(std::chrono::duration<double>(at_s));
    const bool killed = run.Kill9();
    interrupted += killed;
    if (!killed) run_s = std::min(run_s, at_s);
    const CacheState before = ReadCacheState(out);

    const auto resume = RunProgram(RunArgs(out));
    ASSERT_EQ(resume.exit_code, 0) << "resume after kill -9 at " << at_s << " s:\n" << resume.output;
    const auto diff = Differences(reference, PublishedFiles(out));
    EXPECT_TRUE(diff.empty()) << "kill at " << at_s << " s: " << ::testing::PrintToString(diff);
    const auto temporaries = TemporaryNames(out);
    EXPECT_TRUE(temporaries.empty()) << "kill at " << at_s << " s: " << ::testing::PrintToString(temporaries);

    const auto stages = ReadJson(out / "manifest.json")["stages"];
    for (const auto& [stage, record] : stages.items()) {
      if (before.finished_stages.count(stage)) {
        EXPECT_EQ(record["status"], "reused") << stage << " had finished before the kill at " << at_s << " s";
        continue;
      }
      const auto frames = record.value("frames", nlohmann::json::object());
      const auto finished = before.finished_frames.find(stage);
      if (finished == before.finished_frames.end()) continue;
      EXPECT_GE(frames.value("reused", 0), finished->second)
          << stage << ": frames finished before the kill at " << at_s << " s were computed again";
      EXPECT_EQ(frames.value("reused", 0) + frames.value("computed", 0) + frames.value("skipped", 0),
                frames.value("total", -1))
          << stage;
    }
  }
  EXPECT_GE(interrupted, kills / 2) << "most kills must land while the run is still working";
}

}  // namespace
}  // namespace rs::test
