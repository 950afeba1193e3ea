// Per-frame skips: a bad frame costs that frame only, wherever it is found, and is identified by
// frame id and reason in `run`'s summary, manifest.json (stages.<stage>.frames.skipped_frames),
// `roadsurvey status` and, for ingest, the published ingest.json.
// - a corrupt left image found after ingest (ingest.check_images false): the disparity stage
//   skips it without taking the next frame (its temporal prior) along, and slam skips it too;
// - the same image found by ingest's check: listed in ingest.json;
// - a missing right image: a counted, identified skip in ingest, not a survey abort.
#include <fstream>

#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

void TruncateFile(const fs::path& file, size_t bytes) {
  const std::string head = Slurp(file).substr(0, bytes);
  std::ofstream(file, std::ios::binary | std::ios::trunc) << head;
}

// The {frame, reason} pairs of a manifest stage's skipped_frames list.
std::vector<std::pair<int64_t, std::string>> Skipped(const nlohmann::json& stage) {
  std::vector<std::pair<int64_t, std::string>> out;
  for (const auto& s : stage["frames"]["skipped_frames"]) out.emplace_back(s["frame"], s["reason"]);
  return out;
}

using SkipList = std::vector<std::pair<int64_t, std::string>>;

// A stage published results for this frame: its folder (e.g. disparity/000004) holds more than
// the skipped.json a skipped frame leaves.
bool Published(const fs::path& out, const std::string& stage, int frame) {
  char name[16];
  std::snprintf(name, sizeof name, "%06d", frame);
  std::error_code ec;
  for (const auto& f : fs::directory_iterator(out / stage / name, ec))
    if (f.path().filename() != "skipped.json") return true;
  return false;
}

TEST_F(FaultTest, CorruptLeftImageSkipsThatFrameOnlyInEveryStage) {
  const fs::path survey_file = CopySurvey("survey_corrupt_left");
  TruncateFile(survey_file.parent_path() / "left" / "000003.png", 300);
  const fs::path out = Output("corrupt_left");
  const auto r = RunSurveyFile(survey_file, out, "--ingest.check_images false");
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const SkipList frame3 = {{3, "truncated PNG (no IEND chunk)"}};
  const auto m = Manifest(out);
  EXPECT_EQ(Skipped(m["stages"]["disparity"]), frame3);
  EXPECT_EQ(Skipped(m["stages"]["slam"]), frame3);
  EXPECT_EQ(Skipped(m["stages"]["damage"]).size(), 1u);
  EXPECT_EQ(Skipped(m["stages"]["damage"])[0].first, 3);
  EXPECT_EQ(m["stages"]["disparity"]["frames"]["skipped_frames"][0]["where"],
            (survey_file.parent_path() / "left" / "000003.png").string() + " @ byte 300");
  EXPECT_EQ(m["stages"]["slam"]["status"], "computed");

  // run's summary and status name the frame and the reason; frame 4 is not skipped.
  EXPECT_NE(r.output.find("skipped frame 3: truncated PNG (no IEND chunk)"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("skipped frame 4"), std::string::npos) << r.output;
  const auto status = RunProgram("status " + out.string());
  EXPECT_EQ(status.exit_code, 0) << status.output;
  EXPECT_NE(status.output.find("skipped frame 3: truncated PNG (no IEND chunk)"), std::string::npos) << status.output;

  // Downstream outputs for every good frame, the next one included.
  for (int f = 0; f < 8; ++f) {
    EXPECT_EQ(Published(out, "disparity", f), f != 3) << "disparity frame " << f;
    EXPECT_EQ(Published(out, "damage", f), f != 3) << "damage frame " << f;
  }
  EXPECT_TRUE(fs::exists(out / "disparity" / "000004" / "disparity.png"));
  EXPECT_EQ(TumPoses(out / "trajectory.tum"), 7);

  // A re-run reuses the stages and still reports the skips.
  const auto again = RunSurveyFile(survey_file, out, "--ingest.check_images false");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(Manifest(out)["stages"]["disparity"]["status"], "reused");
  EXPECT_EQ(Skipped(Manifest(out)["stages"]["disparity"]), frame3);
  EXPECT_NE(again.output.find("skipped frame 3: truncated PNG"), std::string::npos) << again.output;
}

TEST_F(FaultTest, CorruptLeftImageFoundByIngestIsListedInIngestJson) {
  const fs::path survey_file = CopySurvey("survey_corrupt_checked");
  TruncateFile(survey_file.parent_path() / "left" / "000003.png", 300);
  const fs::path out = Output("corrupt_checked");
  const auto r = RunSurveyFile(survey_file, out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const SkipList frame3 = {{3, "truncated PNG (no IEND chunk)"}};
  EXPECT_EQ(Skipped(Manifest(out)["stages"]["ingest"]), frame3);
  const auto ingest = ReadJson(out / "ingest.json");
  ASSERT_EQ(ingest["skipped_frames"].size(), 1u) << ingest.dump(2);
  EXPECT_EQ(ingest["skipped_frames"][0]["frame"], 3);
  EXPECT_EQ(ingest["skipped_frames"][0]["reason"], "truncated PNG (no IEND chunk)");
  EXPECT_EQ(ingest["frames_usable"], 7);
  EXPECT_NE(r.output.find("skipped frame 3: truncated PNG"), std::string::npos) << r.output;
}

TEST_F(FaultTest, MissingRightImageIsAnIdentifiedSkipNotAnAbort) {
  const fs::path survey_file = CopySurvey("survey_missing_right");
  const fs::path right = survey_file.parent_path() / "right" / "000005.png";
  fs::remove(right);
  const fs::path out = Output("missing_right");
  const auto r = RunSurveyFile(survey_file, out);
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const SkipList frame5 = {{5, "right image missing"}};
  const auto m = Manifest(out);
  EXPECT_EQ(Skipped(m["stages"]["ingest"]), frame5);
  EXPECT_EQ(m["stages"]["ingest"]["frames"]["skipped_frames"][0]["where"], right.string());
  EXPECT_EQ(m["stages"]["ingest"]["frames"]["skipped"], 1);
  EXPECT_EQ(ReadJson(out / "ingest.json")["skipped_frames"][0]["frame"], 5);
  EXPECT_NE(r.output.find("skipped frame 5: right image missing (" + right.string() + ")"), std::string::npos)
      << r.output;
  const auto status = RunProgram("status " + out.string());
  EXPECT_NE(status.output.find("skipped frame 5: right image missing"), std::string::npos) << status.output;

  for (int f = 0; f < 8; ++f) EXPECT_EQ(Published(out, "disparity", f), f != 5) << "disparity frame " << f;
  EXPECT_EQ(TumPoses(out / "trajectory.tum"), 7);
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});
}

}  // namespace
}  // namespace rs::test
