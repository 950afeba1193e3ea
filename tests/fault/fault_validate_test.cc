// `validate` and `run` agree on bad and damaged inputs: each case below is run through both, which
// must give the same exit code and the same message; `run` refuses up front (nothing computed)
// what `validate` rejects. Also: `validate` lists each problem once, and a ULog cut short (power
// loss) is read up to its last complete message with a note saying how much was read.
#include <algorithm>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

class FaultValidate : public FaultTest {
 protected:
  /// A copy of the demo survey file beside it (its relative paths still resolve), with `edit`
  /// applied and its output at `out`.
  static fs::path Variant(const std::string& name, const fs::path& out,
                          const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json doc = ReadJson(SurveyFile());
    doc["output"] = out.string();
    edit(doc);
    const fs::path path = SurveyFile().parent_path() / (name + ".json");
    std::ofstream(path) << doc.dump(1);
    return path;
  }

  /// The first `fraction` of a file of the simulated survey, written beside it as `name`.
  static std::string CutCopy(const std::string& file, double fraction, const std::string& name) {
    const std::string bytes = Slurp(SurveyFile().parent_path() / file);
    std::ofstream(SurveyFile().parent_path() / name, std::ios::binary)
        << bytes.substr(0, static_cast<size_t>(fraction * bytes.size()));
    return name;
  }

  static ProgramResult Validate(const fs::path& survey) { return RunProgram("validate " + survey.string()); }
  static ProgramResult RunSurveyFile(const fs::path& survey) {
    return RunProgram("run " + survey.string() + " --progress quiet");
  }

  /// The lines of `text` that start with `prefix` ("error: ", "warning: ").
  static std::vector<std::string> Lines(const std::string& text, const std::string& prefix) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
      if (line.rfind(prefix, 0) == 0) out.push_back(line);
    return out;
  }

  /// The ingest stage's warnings in the run's manifest.
  static std::string IngestWarnings(const fs::path& out) {
    if (!fs::exists(out / "manifest.json")) return "";
    return Manifest(out)["stages"]["ingest"].value("warnings", nlohmann::json::array()).dump();
  }

  /// Both commands fail with exit 2 and the same error lines; the run computed nothing.
  static void ExpectBothRefuse(const fs::path& survey, const fs::path& out, const std::string& expected) {
    const auto v = Validate(survey);
    const auto r = RunSurveyFile(survey);
    EXPECT_EQ(v.exit_code, 2) << v.output;
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(v.output.find(expected), std::string::npos) << v.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_EQ(Lines(v.output, "error: "), Lines(r.output, "error: ")) << "validate:\n"
                                                                      << v.output << "run:\n"
                                                                      << r.output;
    EXPECT_FALSE(fs::exists(out / "work")) << "nothing is computed for a survey validate rejects";
  }
};

// A configured clock_offset_s that puts the frames outside the log: an error in both that names
// the option, the log and both time ranges (before: `run` replaced it with an estimate, exit 0).
TEST_F(FaultValidate, ConfiguredClockOffsetOutsideTheLogFailsBoth) {
  const fs::path out = Output("offset");
  const fs::path survey =
      Variant("offset", out, [](nlohmann::json& d) { d["inputs"]["flight_log"]["clock_offset_s"] = 1000; });
  ExpectBothRefuse(survey, out, "inputs.flight_log.clock_offset_s = 1000 s puts the frames outside this log");
  const auto v = Validate(survey);
  EXPECT_NE(v.output.find("flight_log.csv"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("8 frames at log time"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("log from"), std::string::npos) << v.output;
}

// A DataFlash log cut before most frames: both read it to the cut (with the note) and both fail
// on the frames outside its span (before: `validate` passed it, `run` failed).
TEST_F(FaultValidate, TruncatedDataflashJudgedTheSameByBoth) {
  const fs::path out = Output("bin_short");
  const std::string log = CutCopy("flight_log.bin", 0.45, "flight_log_short.bin");
  const fs::path survey = Variant("bin_short", out, [&](nlohmann::json& d) {
    d["inputs"]["flight_log"] = {{"path", log}};
  });
  ExpectBothRefuse(survey, out, "of frames fall inside the log's time span");
  EXPECT_NE(Validate(survey).output.find("truncated message at end of file"), std::string::npos);
}

// A DataFlash log cut near its end still covers the frames: both pass, both say it was cut.
TEST_F(FaultValidate, TruncatedDataflashCoveringTheFramesPassesBothWithANote) {
  const fs::path out = Output("bin_cut");
  const std::string log = CutCopy("flight_log.bin", 0.95, "flight_log_cut.bin");
  const fs::path survey = Variant("bin_cut", out, [&](nlohmann::json& d) {
    d["inputs"]["flight_log"] = {{"path", log}};
  });
  const auto v = Validate(survey);
  const auto r = RunSurveyFile(survey);
  EXPECT_EQ(v.exit_code, 0) << v.output;
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(v.output.find("truncated message at end of file"), std::string::npos) << v.output;
  EXPECT_NE(IngestWarnings(out).find("truncated message at end of file"), std::string::npos) << IngestWarnings(out);
}

// Log times going backwards: a warning in both naming the file and the line of the record.
TEST_F(FaultValidate, BackwardsLogTimesWarnInBothWithTheLine) {
  const fs::path dir = SurveyFile().parent_path();
  std::vector<std::string> lines;
  {
    std::ifstream in(dir / "flight_log.csv");
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  // Swap two GNSS rows: the later one (1-based line `b`) now comes first.
  std::vector<size_t> gnss;
  for (size_t i = 0; i < lines.size(); ++i)
    if (lines[i].find(",gnss,") != std::string::npos) gnss.push_back(i);
  ASSERT_GT(gnss.size(), 12u);
  std::swap(lines[gnss[10]], lines[gnss[11]]);
  {
    std::ofstream o(dir / "flight_log_backwards.csv");
    for (const auto& l : lines) o << l << "\n";
  }
  const std::string where = (dir / "flight_log_backwards.csv").string() + ":" + std::to_string(gnss[11] + 1);
  const fs::path out = Output("backwards");
  const fs::path survey = Variant("backwards", out, [](nlohmann::json& d) {
    d["inputs"]["flight_log"] = {{"path", "flight_log_backwards.csv"}};
  });
  const auto v = Validate(survey);
  const auto r = RunSurveyFile(survey);
  EXPECT_EQ(v.exit_code, 0) << v.output;
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(v.output.find("time goes backwards"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("fix at " + where), std::string::npos) << v.output;
  EXPECT_NE(IngestWarnings(out).find("fix at " + where), std::string::npos) << IngestWarnings(out);
}

// An output path that is a file: exit 2 in both, naming it (before: `validate` passed, `run` exit 1).
TEST_F(FaultValidate, OutputPathThatIsAFileFailsBoth) {
  const fs::path file = Output("file");
  std::ofstream(file) << "not a folder";
  const fs::path survey = Variant("output_file", file, [](nlohmann::json&) {});
  const auto v = Validate(survey);
  const auto r = RunSurveyFile(survey);
  EXPECT_EQ(v.exit_code, 2) << v.output;
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const std::string expected = "error: " + file.string() + ": the output folder is a file";
  EXPECT_NE(v.output.find(expected), std::string::npos) << v.output;
  EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
  EXPECT_EQ(Slurp(file), "not a folder");
  // A file further up the path is named too.
  const auto under = RunProgram("validate " + survey.string() + " --output " + (file / "sub").string());
  EXPECT_EQ(under.exit_code, 2) << under.output;
  EXPECT_NE(under.output.find("error: " + file.string() + ": a file where the output folder"), std::string::npos)
      << under.output;
}

// `validate` lists each problem once and counts what it lists: a missing right image, a cut PNG
// and a broken calibration file gave 8 lines for 4 problems before.
TEST_F(FaultValidate, EachProblemListedAndCountedOnce) {
  const fs::path src = SurveyFile().parent_path();
  const fs::path copy = root_ / "damaged";
  fs::remove_all(copy);
  fs::copy(src, copy, fs::copy_options::recursive);
  fs::remove(copy / "right" / "000002.png");
  const std::string left4 = Slurp(src / "left" / "000004.png");
  std::ofstream(copy / "left" / "000004.png", std::ios::binary) << left4.substr(0, 100);
  std::ofstream(copy / "calibration.yaml") << "garbage\n";
  const auto v = Validate(copy / "survey.json");
  EXPECT_EQ(v.exit_code, 2) << v.output;
  const auto errors = Lines(v.output, "error: ");
  const auto warnings = Lines(v.output, "warning: ");
  std::set<std::string> distinct(errors.begin(), errors.end());
  EXPECT_EQ(distinct.size(), errors.size()) << v.output;
  std::set<std::string> distinct_warnings(warnings.begin(), warnings.end());
  EXPECT_EQ(distinct_warnings.size(), warnings.size()) << v.output;
  EXPECT_NE(
      v.output.find(std::to_string(errors.size()) + " error(s), " + std::to_string(warnings.size()) + " warning(s)"),
      std::string::npos)
      << v.output;
  // One line per damaged file (the missing image also makes the left/right counts differ). Bad
  // frames are what `run` skips (skip_bad_frames): warnings saying so; the calibration is an error.
  auto count = [&](const std::vector<std::string>& lines, const std::string& s) {
    return std::count_if(lines.begin(), lines.end(), [&](const std::string& e) { return e.find(s) != e.npos; });
  };
  EXPECT_EQ(count(warnings, "right/000002.png does not exist"), 1) << v.output;
  EXPECT_EQ(count(warnings, "left/000004.png"), 1) << v.output;
  EXPECT_EQ(count(warnings, "will be skipped"), 1) << v.output;
  EXPECT_EQ(count(warnings, "holds 8 images but right/ holds 7"), 1) << v.output;
  EXPECT_EQ(count(errors, "calibration.yaml"), 1) << v.output;
  EXPECT_EQ(errors.size(), 1u) << v.output;
}

// A ULog cut short (power loss) is read up to its last complete message in both commands, with a
// note saying how much was read (before: rejected outright, `@ byte N: truncated message`).
TEST_F(FaultValidate, UlogCutShortIsReadToTheCutWithANote) {
  const fs::path out = Output("ulog_cut");
  const size_t full = Slurp(SurveyFile().parent_path() / "flight_log.ulg").size();
  const std::string log = CutCopy("flight_log.ulg", 0.95, "flight_log_cut.ulg");
  const fs::path survey = Variant("ulog_cut", out, [&](nlohmann::json& d) {
    d["inputs"]["flight_log"] = {{"path", log}};
  });
  const auto v = Validate(survey);
  const auto r = RunSurveyFile(survey);
  EXPECT_EQ(v.exit_code, 0) << v.output;
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const std::string read_of = "of " + std::to_string(static_cast<size_t>(0.95 * full)) + " bytes";
  EXPECT_NE(v.output.find("log cut short"), std::string::npos) << v.output;
  EXPECT_NE(v.output.find(read_of), std::string::npos) << v.output;
  EXPECT_NE(v.output.find("complete messages"), std::string::npos) << v.output;
  EXPECT_NE(IngestWarnings(out).find(read_of), std::string::npos) << IngestWarnings(out);
  const auto ingest = ReadJson(out / "ingest.json");
  EXPECT_EQ(ingest["flight_log"]["format"], "px4-ulog");
  EXPECT_GT(ingest["flight_log"]["fixes"].get<int>(), 0);
}

}  // namespace
}  // namespace rs::test
