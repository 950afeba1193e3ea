// Frame-range runs and the input fingerprint:
// - `--frames` selecting no frame is a usage error (exit 2) stating the survey's frame range,
//   and publishes nothing;
// - a frame-range run is cached apart from the full run and published in its own folder
//   (<output>/frames-A-B/): the full run's published files and cache are left as they were;
// - an output folder that is the survey's frames folder (`"output": "."`) or lies inside it
//   never changes the input keys: a second run reuses every stage.
#include <set>

#include "tests/fault/fault_fixture.h"

namespace rs::test {
namespace {
namespace fs = std::filesystem;

const char* const kStages[] = {"ingest", "disparity", "damage", "slam"};

// Published files of the full run: those outside frame-range folders.
std::map<std::string, std::string> FullRunFiles(const fs::path& out) {
  auto files = PublishedFiles(out);
  std::erase_if(files, [](const auto& kv) { return kv.first.rfind("frames-", 0) == 0; });
  return files;
}

// Bytes of every file in the cache folders that exist now, by path below work/.
std::map<std::string, std::string> CacheFiles(const fs::path& out) { return PublishedFiles(out / "work"); }

// "<stage>/<key>" of a path below work/.
std::string StageKeyFolder(const fs::path& rel) {
  auto it = rel.begin();
  const std::string stage = (it++)->string();
  return stage + "/" + it->string();
}

// Cache folders (work/<stage>/<key>).
std::set<std::string> CacheFolders(const fs::path& out) {
  std::set<std::string> folders;
  for (const auto& stage : fs::directory_iterator(out / "work"))
    for (const auto& key : fs::directory_iterator(stage.path()))
      folders.insert(fs::relative(key.path(), out / "work").string());
  return folders;
}

void ExpectAllReused(const fs::path& manifest_dir) {
  const auto m = ReadJson(manifest_dir / "manifest.json");
  for (const char* stage : kStages) EXPECT_EQ(m["stages"][stage]["status"], "reused") << stage;
}

TEST_F(FaultTest, FramesSelectingNoFrameIsBadInputStatingTheRange) {
  const fs::path out = Output("no_frame");
  const auto r = Run(out, "--frames 100:200");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--frames 100:200 selects no frame: the survey has 8 frames, ids 0 to 7"), std::string::npos)
      << r.output;
  for (const auto& [name, bytes] : PublishedFiles(out))
    EXPECT_NE(fs::path(name).filename(), "trajectory.tum") << "published " << name;
  EXPECT_FALSE(fs::exists(out / "trajectory.tum"));
}

TEST_F(FaultTest, FrameRangeRunIsCachedAndPublishedApartFromTheFullRun) {
  const fs::path out = Output("range");
  ASSERT_EQ(Run(out).exit_code, 0);
  const auto full_files = FullRunFiles(out);
  const std::string full_manifest = Slurp(out / "manifest.json");
  const auto full_cache = CacheFiles(out);
  const auto full_folders = CacheFolders(out);

  const auto r = Run(out, "--frames 0:4");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Outputs in " + (out / "frames-0-4").string()), std::string::npos) << r.output;

  // The full run is untouched: published files, manifest, every file of its cache folders.
  EXPECT_EQ(Differences(full_files, FullRunFiles(out)), std::vector<std::string>{});
  EXPECT_EQ(Slurp(out / "manifest.json"), full_manifest);
  auto cache_now = CacheFiles(out);
  std::erase_if(cache_now, [&](const auto& kv) { return !full_folders.count(StageKeyFolder(kv.first)); });
  EXPECT_EQ(Differences(full_cache, cache_now), std::vector<std::string>{});
  EXPECT_EQ(CacheFolders(out).size(), 2 * full_folders.size()) << "each stage: one folder per selection";

  // The range run's own folder: 4 frames, its own manifest.
  const fs::path range = out / "frames-0-4";
  EXPECT_EQ(TumPoses(range / "trajectory.tum"), 4);
  EXPECT_EQ(TumPoses(out / "trajectory.tum"), 8);
  std::set<std::string> disparity_frames;
  for (const auto& f : fs::directory_iterator(range / "disparity")) disparity_frames.insert(f.path().filename());
  EXPECT_EQ(disparity_frames, (std::set<std::string>{"000000", "000001", "000002", "000003"}));
  // Each frame's disparity does not depend on the selection (same previous frame, same prior).
  for (const auto& f : disparity_frames)
    EXPECT_EQ(Slurp(range / "disparity" / f / "disparity.png"), Slurp(out / "disparity" / f / "disparity.png")) << f;
  const auto m = Manifest(range);
  EXPECT_EQ(m["run"]["frames"], "0:4");
  EXPECT_EQ(m["run"]["state"], "succeeded");
  EXPECT_EQ(m["stages"]["slam"]["frames"]["total"], 4);
  EXPECT_EQ(TemporaryNames(out), std::vector<std::string>{});

  // Both are cached: re-running either reuses every stage and changes nothing.
  ASSERT_EQ(Run(out).exit_code, 0);
  ExpectAllReused(out);
  EXPECT_EQ(Slurp(out / "trajectory.tum"), full_files.at("trajectory.tum"));
  ASSERT_EQ(Run(out, "--frames 0:4").exit_code, 0);
  ExpectAllReused(range);
}

TEST_F(FaultTest, OutputThatIsTheSurveyFolderHitsTheCache) {
  // "output": "." puts the cache and published files among the frames (the frames folder is ".").
  const fs::path survey_file = CopySurvey("survey_dot");
  auto survey = ReadJson(survey_file);
  survey["output"] = ".";
  std::ofstream(survey_file) << survey.dump(2);
  const fs::path out = survey_file.parent_path();

  auto r = RunSurveyFile(survey_file, "");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto folders = CacheFolders(out);
  const std::string trajectory = Slurp(out / "trajectory.tum");
  r = RunSurveyFile(survey_file, "");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ExpectAllReused(out);
  EXPECT_EQ(CacheFolders(out), folders) << "no new cache folder";
  EXPECT_EQ(Slurp(out / "trajectory.tum"), trajectory);

  // An input change is still seen: a new flight-log time stamp recomputes ingest.
  fs::last_write_time(out / "flight_log.csv", fs::last_write_time(out / "flight_log.csv") + std::chrono::seconds(5));
  r = RunSurveyFile(survey_file, "");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(Manifest(out)["stages"]["ingest"]["status"], "computed");
}

TEST_F(FaultTest, OutputInsideTheSurveyFolderHitsTheCache) {
  const fs::path survey_file = CopySurvey("survey_nested");
  const fs::path out = survey_file.parent_path() / "results" / "run1";
  ASSERT_EQ(RunSurveyFile(survey_file, out).exit_code, 0);
  const auto folders = CacheFolders(out);
  const auto r = RunSurveyFile(survey_file, out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ExpectAllReused(out);
  EXPECT_EQ(CacheFolders(out), folders);
}

}  // namespace
}  // namespace rs::test
