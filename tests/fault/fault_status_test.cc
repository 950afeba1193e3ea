// `roadsurvey status`: stages in pipeline order, and a run killed with kill -9 shown as
// interrupted (its process is gone) rather than "running" forever, with everything the output
// folder actually publishes listed.
#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

using FaultStatus = FaultTest;

// Positions of `names` in `text`, in the order given; -1 when missing.
std::vector<long> Positions(const std::string& text, const std::vector<std::string>& names) {
  std::vector<long> at;
  for (const auto& n : names) {
    const auto p = text.find("\n" + n + " ");
    at.push_back(p == std::string::npos ? -1 : static_cast<long>(p));
  }
  return at;
}

TEST_F(FaultStatus, StagesInPipelineOrder) {
  const fs::path out = Output("order");
  ASSERT_EQ(Run(out).exit_code, 0);
  const auto s = RunProgram("status " + out.string());
  EXPECT_EQ(s.exit_code, 0) << s.output;
  const auto at = Positions(s.output, {"ingest", "disparity", "damage", "slam"});
  for (size_t i = 0; i < at.size(); ++i) ASSERT_GE(at[i], 0) << s.output;
  EXPECT_LT(at[0], at[1]) << s.output;  // ingest feeds disparity and slam
  EXPECT_LT(at[1], at[2]) << s.output;  // disparity feeds damage
  EXPECT_LT(at[0], at[3]) << s.output;
}

TEST_F(FaultStatus, KilledRunIsInterruptedAndListsWhatIsPublished) {
  const fs::path out = Output("killed");
  ASSERT_EQ(Run(out).exit_code, 0);
  {
    BackgroundRun run(RunArgs(out, "--rerun-from ingest"));
    // Killed after the manifest says "running" with the first stage done.
    ASSERT_TRUE(WaitUntil([&] {
      try {
        const auto m = Manifest(out);
        return m["run"]["state"] == "running" && m["stages"].contains("ingest");
      } catch (const std::exception&) {
        return false;
      }
    }));
    ASSERT_TRUE(run.Kill9()) << "the run finished before the kill";
  }
  ASSERT_EQ(Manifest(out)["run"]["state"], "running");
  const auto s = RunProgram("status " + out.string());
  EXPECT_EQ(s.exit_code, 1) << s.output;
  EXPECT_NE(s.output.find("interrupted"), std::string::npos) << s.output;
  EXPECT_EQ(s.output.find(", running;"), std::string::npos) << s.output;
  for (const std::string name : {"ingest.json", "disparity", "damage", "trajectory.tum", "keyframes.tum"})
    EXPECT_NE(s.output.find("  " + name), std::string::npos) << name << " is published:\n" << s.output;
}

}  // namespace
}  // namespace rs::test
