// End-to-end behaviour of `roadsurvey run` on a small simulated survey: cache
// reuse, option changes, kill -9 resume, bad input, exit codes. Runs the built
// program exactly as a user would.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "survey/survey_file.h"
#include "tests/support/run_program.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

class PipelineE2E : public ::testing::Test {
 protected:
  // One small simulated survey shared by every test (simulation is the slow part).
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("rs_pipeline_e2e_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    const auto r = RunProgram("simulate " + (root_ / "survey").string() +
                              " --preset demo --num_frames 16 --image_width 640 --image_height 360 --focal_px 500"
                              " --cx_px 320 --cy_px 180 --progress quiet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // A fresh output folder per test, through --output.
  fs::path Output(const std::string& name) { return root_ / ("out_" + name); }
  ProgramResult Run(const fs::path& out, const std::string& extra = "") {
    return RunProgram("run " + (root_ / "survey" / "survey.json").string() + " --output " + out.string() +
                      " --progress quiet " + extra);
  }
  static std::map<std::string, std::string> Statuses(const fs::path& out) {
    std::map<std::string, std::string> s;
    const auto manifest = ReadJson(out / "manifest.json");
    for (const auto& [name, stage] : manifest["stages"].items()) s[name] = stage["status"].get<std::string>();
    return s;
  }

  static fs::path root_;
};
fs::path PipelineE2E::root_;

TEST_F(PipelineE2E, Nominal) {
  const fs::path out = Output("nominal");
  const auto r = Run(out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const auto& [stage, status] : Statuses(out)) EXPECT_EQ(status, "computed") << stage;
  for (const char* published : {"trajectory.tum", "ingest.json", "disparity/000000/disparity.png",
                                "damage/000000/detections.json", "damage/000000/labels.png"})
    EXPECT_TRUE(fs::exists(out / published)) << published;
  EXPECT_NE(r.output.find("Outputs in"), std::string::npos) << "the run says where the outputs are";

  // Every detections.json conforms to its published schema.
  const auto schema = ReadJson(fs::path(ROADSURVEY_SOURCE_DIR) / "schemas" / "detections.schema.json");
  int files = 0, damages = 0;
  for (const auto& frame : fs::directory_iterator(out / "damage")) {
    if (!fs::exists(frame.path() / "detections.json")) continue;
    const auto doc = ReadJson(frame.path() / "detections.json");
    const auto problems = ValidateAgainstSchema(doc, schema);
    EXPECT_TRUE(problems.empty()) << frame.path() << ": " << (problems.empty() ? "" : problems.front());
    ++files;
    damages += static_cast<int>(doc["detections"].size());
  }
  EXPECT_EQ(files, 16);
  EXPECT_GT(damages, 0) << "the simulated road has potholes";
}

TEST_F(PipelineE2E, UnchangedRerunDoesNoWork) {
  const fs::path out = Output("rerun");
  ASSERT_EQ(Run(out).exit_code, 0);
  const auto before = fs::last_write_time(out / "disparity" / "000000" / "disparity.png");
  const auto r = Run(out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto manifest = ReadJson(out / "manifest.json");
  for (const auto& [stage, s] : manifest["stages"].items()) {
    EXPECT_EQ(s["status"], "reused") << stage;
    EXPECT_EQ(s["frames"]["computed"], 0) << stage;
  }
  EXPECT_EQ(fs::last_write_time(out / "disparity" / "000000" / "disparity.png"), before);
}

TEST_F(PipelineE2E, OptionChangeRerunsStageAndDependentsOnly) {
  const fs::path out = Output("option");
  ASSERT_EQ(Run(out).exit_code, 0);
  auto r = Run(out, "--damage.segment.min_area_m2 0.01");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto s = Statuses(out);
  EXPECT_EQ(s["ingest"], "reused");
  EXPECT_EQ(s["disparity"], "reused");
  EXPECT_EQ(s["slam"], "reused");
  EXPECT_EQ(s["damage"], "computed");
  EXPECT_EQ(ReadJson(out / "manifest.json")["stages"]["damage"]["options"]["segment.min_area_m2"], 0.01);

  r = Run(out, "--disparity.p2 130 --damage.segment.min_area_m2 0.01");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  s = Statuses(out);
  EXPECT_EQ(s["ingest"], "reused");
  EXPECT_EQ(s["slam"], "reused") << "slam does not read disparities";
  EXPECT_EQ(s["disparity"], "computed");
  EXPECT_EQ(s["damage"], "computed");
}

TEST_F(PipelineE2E, RerunFromAndOnly) {
  const fs::path out = Output("rerun_from");
  ASSERT_EQ(Run(out).exit_code, 0);
  ASSERT_EQ(Run(out, "--rerun-from damage").exit_code, 0);
  auto s = Statuses(out);
  EXPECT_EQ(s["damage"], "computed");
  EXPECT_EQ(s["disparity"], "reused");
  ASSERT_EQ(Run(out, "--only disparity").exit_code, 0);
  s = Statuses(out);
  EXPECT_EQ(s["disparity"], "reused");
  EXPECT_EQ(s["damage"], "not-selected");
}

// Everything under `dir` as relative path -> bytes (cache folders excluded).
std::map<std::string, std::string> Contents(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = Slurp(e.path());
  return files;
}

TEST_F(PipelineE2E, ResumesAfterKill9WithIdenticalOutputs) {
  // Slow disparity settings and one thread so the kill lands mid-stage.
  const std::string slow = "--threads 1 --disparity.method sgm --disparity.num_disparities 192 --disparity.num_paths 8";
  const fs::path reference = Output("kill_reference");
  ASSERT_EQ(Run(reference, slow).exit_code, 0);

  const fs::path out = Output("kill");
  const std::string cmd = ProgramPath().string() + " run " + (root_ / "survey" / "survey.json").string() +
                          " --output " + out.string() + " --progress quiet " + slow;
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::setpgid(0, 0);
    ::execl("/bin/sh", "sh", "-c", ("exec " + cmd + " >/dev/null 2>&1").c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Wait until at least 3 disparity frames are committed, then kill -9.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  int committed = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    committed = 0;
    std::error_code ec;
    for (const auto& key : fs::directory_iterator(out / "work" / "disparity", ec))
      for (const auto& f : fs::directory_iterator(key.path() / "frames", ec))
        committed += f.path().filename().string()[0] != '.';
    if (committed >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run finished before it could be killed";
  ASSERT_GE(committed, 3);
  EXPECT_EQ(ReadJson(out / "manifest.json")["run"]["state"], "running") << "the manifest shows the interrupted run";

  const auto r = Run(out, slow);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto disparity = ReadJson(out / "manifest.json")["stages"]["disparity"];
  EXPECT_EQ(disparity["status"], "computed");
  EXPECT_GE(disparity["frames"]["reused"].get<int>(), committed) << "finished frames are not recomputed";
  EXPECT_EQ(disparity["frames"]["reused"].get<int>() + disparity["frames"]["computed"].get<int>(), 16);
  for (const char* dir : {"disparity", "damage"}) {
    const auto a = Contents(reference / dir), b = Contents(out / dir);
    ASSERT_EQ(a.size(), b.size()) << dir;
    for (const auto& [name, bytes] : a) EXPECT_TRUE(b.count(name) && b.at(name) == bytes) << dir << "/" << name;
  }
  EXPECT_EQ(Slurp(reference / "trajectory.tum"), Slurp(out / "trajectory.tum"));
}

TEST_F(PipelineE2E, CorruptFrameIsSkippedAndCounted) {
  // A copy of the survey with one truncated left image.
  const fs::path copy = root_ / "corrupt";
  fs::remove_all(copy);
  fs::copy(root_ / "survey", copy, fs::copy_options::recursive);
  fs::remove_all(copy / "out");
  const std::string bytes = Slurp(copy / "left" / "000005.png");
  std::ofstream(copy / "left" / "000005.png", std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() / 3);

  // validate says what run will do with it: skip that frame (a warning, exit 0).
  const auto v = RunProgram("validate " + (copy / "survey.json").string());
  EXPECT_EQ(v.exit_code, 0) << v.output;
  EXPECT_NE(v.output.find("000005.png"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("will be skipped"), std::string::npos) << v.output;

  const auto r = RunProgram("run " + (copy / "survey.json").string() + " --progress quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto ingest = ReadJson(copy / "out" / "manifest.json")["stages"]["ingest"];
  EXPECT_EQ(ingest["frames"]["skipped"], 1);
  EXPECT_EQ(ingest["frames"]["skip_reasons"].size(), 1u);
  EXPECT_NE(r.output.find("skipped frame 5: truncated PNG"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(copy / "out" / "disparity" / "000005")) << "downstream stages never see the bad frame";
  EXPECT_TRUE(fs::exists(copy / "out" / "disparity" / "000006"));
}

TEST_F(PipelineE2E, ValidateListsEveryProblemAtOnce) {
  const fs::path copy = root_ / "broken";
  fs::remove_all(copy);
  fs::copy(root_ / "survey", copy, fs::copy_options::recursive);
  const std::string bytes = Slurp(copy / "left" / "000003.png");
  std::ofstream(copy / "left" / "000003.png", std::ios::binary | std::ios::trunc) << bytes.substr(0, 100);
  fs::remove(copy / "right" / "000007.png");
  auto doc = ReadJson(copy / "survey.json");
  doc["inputs"]["flight_log"]["path"] = "no_such_log.ulg";
  std::ofstream(copy / "survey.json") << doc.dump(2);

  const auto r = RunProgram("validate " + (copy / "survey.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  for (const char* named : {"000003.png", "000007.png", "no_such_log.ulg"})
    EXPECT_NE(r.output.find(named), std::string::npos) << named << " not reported:\n" << r.output;
  EXPECT_NE(r.output.find("error(s)"), std::string::npos) << r.output;
}

TEST_F(PipelineE2E, StatusReportsLastRun) {
  const fs::path out = Output("status");
  ASSERT_EQ(Run(out).exit_code, 0);
  const auto r = RunProgram("status " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const char* stage : {"ingest", "disparity", "damage", "slam"})
    EXPECT_NE(r.output.find(stage), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("succeeded"), std::string::npos) << r.output;
  EXPECT_EQ(RunProgram("status " + (root_ / "survey").string()).exit_code, 2) << "not an output folder";
}

TEST_F(PipelineE2E, EvalSimulatedDamage) {
  const auto r = RunProgram("eval damage-sim " + (root_ / "survey").string() + " --truth-disparity --max-frames 4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("recall"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("severity"), std::string::npos) << r.output;
  EXPECT_EQ(RunProgram("eval damage-sim " + (root_ / "nowhere").string()).exit_code, 2);
}

TEST_F(PipelineE2E, ExitCodes) {
  EXPECT_EQ(RunProgram("").exit_code, 2) << "no subcommand";
  EXPECT_EQ(RunProgram("frobnicate").exit_code, 2);
  EXPECT_EQ(RunProgram("run /nonexistent/survey.json").exit_code, 2);
  EXPECT_EQ(RunProgram("validate " + (root_ / "survey" / "survey.json").string()).exit_code, 0);

  const auto bad_value = Run(Output("bad_value"), "--disparity.p2 lots");
  EXPECT_EQ(bad_value.exit_code, 2);
  EXPECT_NE(bad_value.output.find("--disparity.p2 lots: expected integer"), std::string::npos) << bad_value.output;

  const auto broken_rule = Run(Output("broken_rule"), "--disparity.p1 200 --disparity.p2 100");
  EXPECT_EQ(broken_rule.exit_code, 2);
  EXPECT_NE(broken_rule.output.find("p2"), std::string::npos) << broken_rule.output;

  // The output folder is a file: refused up front like `validate` refuses it (bad input).
  const fs::path file = root_ / "not_a_folder";
  std::ofstream(file) << "x";
  EXPECT_EQ(Run(file).exit_code, 2);
}

TEST_F(PipelineE2E, SchemaErrorsNameTheKey) {
  const fs::path survey = root_ / "bad_survey.json";
  auto doc = ReadJson(root_ / "survey" / "survey.json");
  doc["inputs"]["frames"]["path"] = (root_ / "survey").string();
  doc["stages"]["disparity"]["max_disparty"] = 64;   // typo
  doc["stages"]["damage"]["write_overlay"] = "yes";  // ill-typed
  std::ofstream(survey) << doc.dump(2);
  const auto r = RunProgram("validate " + survey.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("/stages/disparity/max_disparty: unknown key"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/stages/damage/write_overlay"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"yes\""), std::string::npos) << r.output;

  std::ofstream(survey) << "{\n  \"name\": \"x\",\n  \"inputs\": {,\n}";
  const auto syntax = RunProgram("validate " + survey.string());
  EXPECT_EQ(syntax.exit_code, 2);
  EXPECT_NE(syntax.output.find("bad_survey.json:3:"), std::string::npos) << syntax.output;
}

}  // namespace
}  // namespace rs::test
