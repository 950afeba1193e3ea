#pragma once
// Shared fixture of the fault-injection tests: one small simulated survey, runs of the built
// program under faults (a file-size limit, an injected write failure, kill -9 at a chosen
// moment, a second run beside the first), and the checks every fault test makes: exit code,
// message, published outputs equal to a clean run's, no temporary names under the output.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/run_program.h"
#include "tests/support/temp_dirs.h"

namespace rs::test {

namespace fault_fs = std::filesystem;

/// Every file under `dir` (recursively) with its bytes, keyed by the path relative to `dir`.
/// Skips `work/` (the cache, compared through what it publishes), `manifest.json` and the report's
/// run record `report/data/run.{js,json}` (times of this run).
inline std::map<std::string, std::string> PublishedFiles(const fault_fs::path& dir) {
  std::map<std::string, std::string> files;
  std::error_code ec;
  for (auto it = fault_fs::recursive_directory_iterator(dir, ec); it != fault_fs::recursive_directory_iterator();
       it.increment(ec)) {
    const fault_fs::path rel = fault_fs::relative(it->path(), dir);
    // The manifest and the report's run record hold this run's times, not results.
    if (rel == "work" || rel == "manifest.json" || rel == "report/data/run.js" || rel == "report/data/run.json") {
      if (it->is_directory()) it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file()) files[rel.string()] = Slurp(it->path());
  }
  return files;
}

/// Paths under `dir` (cache included) whose name marks a temporary or an unfinished write.
inline std::vector<std::string> TemporaryNames(const fault_fs::path& dir) {
  std::vector<std::string> found;
  std::error_code ec;
  for (auto it = fault_fs::recursive_directory_iterator(dir, ec); it != fault_fs::recursive_directory_iterator();
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.find(".tmp") != std::string::npos || name.find(".rerun") != std::string::npos ||
        name.find(".old") != std::string::npos)
      found.push_back(fault_fs::relative(it->path(), dir).string());
  }
  return found;
}

/// Names of the files that differ between two PublishedFiles() snapshots (missing, extra or changed).
inline std::vector<std::string> Differences(const std::map<std::string, std::string>& expected,
                                            const std::map<std::string, std::string>& actual) {
  std::vector<std::string> diff;
  for (const auto& [name, bytes] : expected) {
    const auto it = actual.find(name);
    if (it == actual.end())
      diff.push_back("missing " + name);
    else if (it->second != bytes)
      diff.push_back("changed " + name);
  }
  for (const auto& [name, bytes] : actual)
    if (!expected.count(name)) diff.push_back("extra " + name);
  return diff;
}

/// Polls `done` every few milliseconds until it holds or `timeout_s` passes; returns whether it held.
template <typename Predicate>
bool WaitUntil(Predicate&& done, double timeout_s = 60) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

/// Whether a temporary name (TemporaryNames) exists under `dir` right now.
inline bool HasTemporaryName(const fault_fs::path& dir) { return !TemporaryNames(dir).empty(); }

/// A `roadsurvey` process started in the background (its own process group), output discarded.
class BackgroundRun {
 public:
  explicit BackgroundRun(const std::string& args) {
    const std::string cmd = "exec " + ProgramPath().string() + " " + args + " >/dev/null 2>&1";
    pid_ = ::fork();
    if (pid_ == 0) {
      ::setpgid(0, 0);
      ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  BackgroundRun(const BackgroundRun&) = delete;
  BackgroundRun& operator=(const BackgroundRun&) = delete;
  ~BackgroundRun() {
    if (pid_ > 0 && !waited_) Kill9();
  }
  pid_t pid() const { return pid_; }
  /// kill -9; returns true when the process was still running (the kill interrupted it).
  bool Kill9() {
    ::kill(pid_, SIGKILL);
    return Wait() == -SIGKILL;
  }
  /// Waits for the process; returns its exit code, or minus the signal that ended it.
  int Wait() {
    if (waited_) return status_;
    int status = 0;
    ::waitpid(pid_, &status, 0);
    waited_ = true;
    status_ = WIFEXITED(status) ? WEXITSTATUS(status) : (WIFSIGNALED(status) ? -WTERMSIG(status) : -1000);
    return status_;
  }

 private:
  pid_t pid_ = -1;
  bool waited_ = false;
  int status_ = 0;
};

/// One simulated 8-frame survey per test program, and a clean run of it as the reference.
class FaultTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fault_fs::temp_directory_path() / ("rs_fault_" + std::to_string(::getpid()));
    fault_fs::remove_all(root_);
    RemoveAtExit(root_);
    const auto r = RunProgram("simulate " + (root_ / "survey").string() +
                              " --preset demo --num_frames 8 --image_width 640 --image_height 360 --focal_px 500"
                              " --cx_px 320 --cy_px 180 --progress quiet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    fault_fs::remove_all(root_ / "survey" / "out");
  }

  static fault_fs::path SurveyFile() { return root_ / "survey" / "survey.json"; }

  /// A fresh output folder per use.
  static fault_fs::path Output(const std::string& name) {
    const fault_fs::path out = root_ / ("out_" + name);
    fault_fs::remove_all(out);
    return out;
  }

  /// `roadsurvey run` of the survey into `out`.
  static ProgramResult Run(const fault_fs::path& out, const std::string& extra = "", const std::string& prefix = "") {
    return RunProgramWith(prefix, RunArgs(out, extra));
  }
  static std::string RunArgs(const fault_fs::path& out, const std::string& extra = "") {
    return "run " + SurveyFile().string() + " --output " + out.string() + " --progress quiet " + extra;
  }

  /// What a clean, uninterrupted run publishes with these options. The run happens at the same
  /// output path as the faulty one will (outputs may name their own folder), then that folder is
  /// removed, so call this before the faulty run.
  static std::map<std::string, std::string> CleanRunFiles(const fault_fs::path& out, const std::string& extra = "") {
    fault_fs::remove_all(out);
    const auto r = Run(out, extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    auto files = PublishedFiles(out);
    fault_fs::remove_all(out);
    return files;
  }

  static nlohmann::json Manifest(const fault_fs::path& out) { return ReadJson(out / "manifest.json"); }

  /// A fresh copy of the simulated survey folder (without outputs) to damage or reconfigure;
  /// returns its survey file.
  static fault_fs::path CopySurvey(const std::string& name) {
    const fault_fs::path copy = root_ / name;
    fault_fs::remove_all(copy);
    fault_fs::copy(root_ / "survey", copy, fault_fs::copy_options::recursive);
    return copy / "survey.json";
  }

  /// `roadsurvey run` of another survey file; `out` empty: the survey file's own "output".
  static ProgramResult RunSurveyFile(const fault_fs::path& survey_file, const fault_fs::path& out,
                                     const std::string& extra = "") {
    const std::string output = out.empty() ? std::string() : " --output " + out.string();
    return RunProgramWith("", "run " + survey_file.string() + output + " --progress quiet " + extra);
  }

  /// Poses in a TUM trajectory (lines that are neither empty nor comments).
  static int TumPoses(const fault_fs::path& file) {
    std::istringstream in(Slurp(file));
    int n = 0;
    for (std::string line; std::getline(in, line);) n += !line.empty() && line[0] != '#';
    return n;
  }

  static fault_fs::path root_;
};
inline fault_fs::path FaultTest::root_;

}  // namespace rs::test
