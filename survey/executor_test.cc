// Job-graph behaviour on a small real pipeline of test stages that read and
// write files: list numbers -> scale each (per frame) -> sum; plus a side branch.
#include "survey/executor.h"

#include <gtest/gtest.h>

#include <atomic>
#include <fstream>

#include "survey/atomic_file.h"
#include "survey/survey_schema.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

std::atomic<int> g_list_runs{0}, g_scale_frames{0}, g_sum_runs{0}, g_side_runs{0};
std::atomic<int> g_fail_at_frame{-1};  // scale throws a processing error on this frame

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

struct NoOptions {
  void Check() const {}
  static const OptionTable<NoOptions>& Table() {
    static const OptionTable<NoOptions> t;
    return t;
  }
};

// Lists the number files of the input folder as frames.
class ListStage : public TypedStage<ListStage, NoOptions> {
 public:
  static StageInfo Info() { return {"list", 1, "lists frames", {kSurveyInputs}, {"frames"}, {}, false}; }
  void Run(StageContext& ctx, const NoOptions&) const {
    ++g_list_runs;
    std::vector<FrameRecord> frames;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(*ctx.survey().InputPath("frames")))
      if (e.path().extension() == ".txt") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (size_t i = 0; i < files.size(); ++i)
      frames.push_back({FrameId{static_cast<int64_t>(i)}, static_cast<int64_t>(i) * 100, files[i], files[i]});
    WriteFrameIndex(ctx.out_dir() / "frames.csv", frames);
  }
};

struct ScaleOptions {
  int factor = 2;  // multiplier
  bool skip_bad = true;
  void Check() const {}
  static const OptionTable<ScaleOptions>& Table() {
    static const auto t = OptionTable<ScaleOptions>()
                              .Add("factor", &ScaleOptions::factor, "multiplier")
                              .Add("skip_bad", &ScaleOptions::skip_bad, "skip unreadable frames");
    return t;
  }
};

class ScaleStage : public TypedStage<ScaleStage, ScaleOptions> {
 public:
  static StageInfo Info() {
    StageInfo i{"scale", 1, "scales each frame's number", {"frames"}, {"scaled"}, {}, true};
    return i;
  }
  void Run(StageContext& ctx, const ScaleOptions& o) const {
    const auto frames = ReadFrameIndex(ctx.input_dir("frames") / "frames.csv");
    ctx.ForEachFrame(
        frames,
        [&](const FrameRecord& f, const fs::path& tmp) {
          ++g_scale_frames;
          if (f.id.value == g_fail_at_frame) throw std::runtime_error("simulated crash");
          const std::string text = Slurp(f.left);
          if (text.empty() || !std::isdigit(static_cast<unsigned char>(text[0])))
            throw InputError(InputLocation::Line(f.left.string(), 1), "not a number");
          std::ofstream(tmp / "value.txt") << std::stoi(text) * o.factor;
          return FrameOutcome{{{"values", 1}}, {}};
        },
        o.skip_bad);
  }
};

class SumStage : public TypedStage<SumStage, NoOptions> {
 public:
  static StageInfo Info() {
    return {"sum", 1, "sums", {"frames", "scaled"}, {"total"}, {{"sum.txt", "sum.txt"}}, true};
  }
  void Run(StageContext& ctx, const NoOptions&) const {
    ++g_sum_runs;
    const auto frames = ReadFrameIndex(ctx.input_dir("frames") / "frames.csv");
    int64_t sum = 0;
    for (size_t i = 0; i < frames.size(); ++i) {
      if (!ctx.frame_selection().Contains(frames[i].id.value)) continue;
      const fs::path v = StageContext::FrameDirIn(ctx.input_dir("scaled"), frames[i].id) / "value.txt";
      if (fs::exists(v)) sum += std::stoll(Slurp(v));
    }
    WriteFileAtomic(ctx.out_dir() / "sum.txt", std::to_string(sum));
  }
};

struct SideOptions {
  int x = 0;  // unused knob
  void Check() const { CheckRule(x >= 0, "side", "x", x, "x >= 0"); }
  static const OptionTable<SideOptions>& Table() {
    static const auto t = OptionTable<SideOptions>().Add("x", &SideOptions::x, "unused knob");
    return t;
  }
};

// What the side stage's outputs depend on beyond inputs and options (as a model file's digest).
std::string g_side_extra;

class SideStage : public TypedStage<SideStage, SideOptions> {
 public:
  static StageInfo Info() { return {"side", 1, "independent branch", {"frames"}, {"side"}, {}, false}; }
  std::string ExtraKeyOf(const SurveyFile&, const SideOptions&) const { return g_side_extra; }
  void Run(StageContext& ctx, const SideOptions&) const {
    ++g_side_runs;
    WriteFileAtomic(ctx.out_dir() / "n.txt", "ok");
  }
};

class ExecutorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("rs_executor_test_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_ / "numbers");
    for (int i = 0; i < 10; ++i) std::ofstream(root_ / "numbers" / (std::to_string(100 + i) + ".txt")) << i + 1;
    registry_.Add(std::make_unique<ListStage>());
    registry_.Add(std::make_unique<ScaleStage>());
    registry_.Add(std::make_unique<SumStage>());
    registry_.Add(std::make_unique<SideStage>());
    doc_ = {{"name", "t"}, {"inputs", {{"frames", {{"path", "numbers"}}}}}, {"output", "out"}};
    g_list_runs = g_scale_frames = g_sum_runs = g_side_runs = 0;
    g_fail_at_frame = -1;
    g_side_extra.clear();
  }
  void TearDown() override { fs::remove_all(root_); }

  SurveyFile Survey() { return SurveyFromJson(doc_, root_ / "survey.json", BuildSurveySchema(registry_)); }
  RunReport Run(RunRequest req = {}) {
    req.progress = Progress::Mode::kQuiet;
    return RunSurvey(registry_, Survey(), req);
  }
  std::string Status(const RunReport& r, const std::string& stage) { return ToString(r.Find(stage)->status); }

  fs::path root_;
  StageRegistry registry_;
  nlohmann::json doc_;
};

TEST_F(ExecutorTest, Nominal) {
  const auto r = Run();
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "110");  // 2 * (1 + ... + 10)
  EXPECT_EQ(g_scale_frames, 10);
  const auto manifest = ReadJsonFile(root_ / "out" / "manifest.json");
  EXPECT_EQ(manifest["run"]["state"], "succeeded");
  EXPECT_EQ(manifest["stages"]["scale"]["status"], "computed");
  EXPECT_EQ(manifest["stages"]["scale"]["frames"]["computed"], 10);
  EXPECT_EQ(manifest["stages"]["scale"]["options"]["factor"], 2);
  EXPECT_EQ(manifest["published"].count("sum.txt"), 1u);
}

TEST_F(ExecutorTest, UnchangedRerunDoesNoWork) {
  Run();
  const int list = g_list_runs, frames = g_scale_frames, sum = g_sum_runs, side = g_side_runs;
  const auto r = Run();
  EXPECT_EQ(g_list_runs, list);
  EXPECT_EQ(g_scale_frames, frames);
  EXPECT_EQ(g_sum_runs, sum);
  EXPECT_EQ(g_side_runs, side);
  for (const char* s : {"list", "scale", "sum", "side"}) EXPECT_EQ(Status(r, s), "reused") << s;
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "110");
}

TEST_F(ExecutorTest, OptionChangeRerunsStageAndDependentsOnly) {
  Run();
  doc_["stages"]["scale"]["factor"] = 3;
  const auto r = Run();
  EXPECT_EQ(Status(r, "list"), "reused");
  EXPECT_EQ(Status(r, "side"), "reused");
  EXPECT_EQ(Status(r, "scale"), "computed");
  EXPECT_EQ(Status(r, "sum"), "computed");
  EXPECT_EQ(g_list_runs, 1);
  EXPECT_EQ(g_side_runs, 1);
  EXPECT_EQ(g_scale_frames, 20);
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "165");
  // Back to the first options: both runs are cached, nothing is recomputed.
  doc_["stages"]["scale"]["factor"] = 2;
  const auto r2 = Run();
  EXPECT_EQ(Status(r2, "scale"), "reused");
  EXPECT_EQ(Status(r2, "sum"), "reused");
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "110");
}

// A stage's extra key (a model's digest) reruns that stage alone when it changes.
TEST_F(ExecutorTest, ExtraKeyChangeRerunsThatStageOnly) {
  Run();
  g_side_extra = "model_sha256=1234";
  const auto r = Run();
  EXPECT_EQ(Status(r, "side"), "computed");
  for (const char* s : {"list", "scale", "sum"}) EXPECT_EQ(Status(r, s), "reused") << s;
  g_side_extra.clear();  // the first key again: cached
  EXPECT_EQ(Status(Run(), "side"), "reused");
}

TEST_F(ExecutorTest, CliOverrideChangesKeyLikeSurveyOption) {
  Run();
  RunRequest req;
  req.cli_overrides = {{"side", {{"x", 4}}}};
  const auto r = Run(req);
  EXPECT_EQ(Status(r, "side"), "computed");
  EXPECT_EQ(Status(r, "scale"), "reused");
  EXPECT_EQ(r.Find("side")->options["x"], 4);
}

TEST_F(ExecutorTest, InputFileChangeRerunsEverything) {
  Run();
  std::ofstream(root_ / "numbers" / "200.txt") << 5;
  const auto r = Run();
  for (const char* s : {"list", "scale", "sum", "side"}) EXPECT_EQ(Status(r, s), "computed") << s;
  EXPECT_EQ(r.Find("scale")->summary.frames_computed, 11) << "a new input key means a new cache folder";
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "120");
}

TEST_F(ExecutorTest, OutputInsideInputFolderIsNotAnInput) {
  doc_["output"] = "numbers/out";  // like a simulated survey: frames at ".", output "out"
  Run();
  const auto r = Run();
  for (const char* s : {"list", "scale", "sum", "side"}) EXPECT_EQ(Status(r, s), "reused") << s;
}

TEST_F(ExecutorTest, RerunFromForcesStageAndDependents) {
  Run();
  RunRequest req;
  req.rerun_from = "scale";
  const auto r = Run(req);
  EXPECT_EQ(Status(r, "list"), "reused");
  EXPECT_EQ(Status(r, "side"), "reused");
  EXPECT_EQ(Status(r, "scale"), "computed");
  EXPECT_EQ(Status(r, "sum"), "computed");
  EXPECT_EQ(g_scale_frames, 20);
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "110");
}

TEST_F(ExecutorTest, OnlyNeedsCachedInputs) {
  RunRequest req;
  req.only = "sum";
  const auto r = Run(req);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(Status(r, "sum"), "blocked");
  EXPECT_NE(r.Find("sum")->error.find("run without --only first"), std::string::npos);
  Run();
  const auto r2 = Run(req);
  EXPECT_EQ(r2.exit_code, 0);
  EXPECT_EQ(Status(r2, "sum"), "reused");
  EXPECT_EQ(Status(r2, "scale"), "not-selected");
}

TEST_F(ExecutorTest, ResumeAfterFailureKeepsFinishedFrames) {
  RunRequest req;
  req.threads = 1;
  g_fail_at_frame = 6;
  const auto r = Run(req);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(Status(r, "scale"), "failed");
  EXPECT_EQ(Status(r, "sum"), "blocked");
  EXPECT_EQ(Status(r, "side"), "computed") << "independent branches still run";
  const auto manifest = ReadJsonFile(root_ / "out" / "manifest.json");
  EXPECT_EQ(manifest["run"]["state"], "failed");
  EXPECT_NE(manifest["stages"]["scale"]["error"].get<std::string>().find("simulated crash"), std::string::npos);

  g_fail_at_frame = -1;
  g_scale_frames = 0;
  const auto r2 = Run(req);
  EXPECT_EQ(r2.exit_code, 0);
  const auto& rec = *r2.Find("scale");
  EXPECT_EQ(rec.summary.frames_reused, 6);
  EXPECT_EQ(rec.summary.frames_computed, 4);
  EXPECT_EQ(g_scale_frames, 4);
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "110");
}

TEST_F(ExecutorTest, BadFrameIsSkippedAndCounted) {
  std::ofstream(root_ / "numbers" / "105.txt", std::ios::trunc) << "garbage";
  const auto r = Run();
  EXPECT_EQ(r.exit_code, 0);
  const auto& rec = *r.Find("scale");
  EXPECT_EQ(rec.summary.frames_skipped, 1);
  EXPECT_EQ(rec.summary.skip_reasons.at("not a number"), 1);
  // Identified by frame id (105.txt is the 6th file: id 5), reason and file, here and in the manifest.
  ASSERT_EQ(rec.summary.skipped.size(), 1u);
  EXPECT_EQ(rec.summary.skipped[0].frame, 5);
  EXPECT_EQ(rec.summary.skipped[0].reason, "not a number");
  EXPECT_EQ(rec.summary.skipped[0].where, (root_ / "numbers" / "105.txt").string() + ":1");
  const auto listed = ReadJsonFile(r.manifest_path)["stages"]["scale"]["frames"]["skipped_frames"];
  EXPECT_EQ(listed, nlohmann::json::parse(R"([{"frame": 5, "reason": "not a number", "where": ")" +
                                          (root_ / "numbers" / "105.txt").string() + R"(:1"}])"));
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "98");  // 110 - 2 * 6
  // The skip is cached and still reported on a resumed run.
  RunRequest only_scale;
  only_scale.only = "scale";
  const auto r2 = Run(only_scale);
  EXPECT_EQ(Status(r2, "scale"), "reused");
  EXPECT_EQ(r2.Find("scale")->summary.frames_skipped, 1) << "reused runs report the cached run's summary";
  EXPECT_EQ(r2.Find("scale")->summary.skip_reasons.at("not a number"), 1);
  ASSERT_EQ(r2.Find("scale")->summary.skipped.size(), 1u);
  EXPECT_EQ(r2.Find("scale")->summary.skipped[0].frame, 5);
}

TEST(StageSummary, SkippedFramesListedByIdWhateverTheOrderTheyFinished) {
  StageSummary s;
  s.skipped = {{7, "truncated PNG (no IEND chunk)", "left/000007.png @ byte 300"}, {2, "right image missing", ""}};
  const auto j = s.ToJson();
  const auto expected = nlohmann::json::parse(R"js([
    {"frame": 2, "reason": "right image missing"},
    {"frame": 7, "reason": "truncated PNG (no IEND chunk)", "where": "left/000007.png @ byte 300"}])js");
  EXPECT_EQ(j["frames"]["skipped_frames"], expected);
  const StageSummary back = StageSummary::FromJson(j);
  ASSERT_EQ(back.skipped.size(), 2u);
  EXPECT_EQ(back.skipped[0].frame, 2);
  EXPECT_EQ(back.skipped[1].where, "left/000007.png @ byte 300");
}

TEST_F(ExecutorTest, BadFrameFailsStageWhenNotSkipping) {
  std::ofstream(root_ / "numbers" / "105.txt", std::ios::trunc) << "garbage";
  doc_["stages"]["scale"]["skip_bad"] = false;
  const auto r = Run();
  EXPECT_EQ(r.exit_code, 2) << "bad input is exit code 2";
  EXPECT_NE(r.Find("scale")->error.find("105.txt:1: not a number"), std::string::npos) << r.Find("scale")->error;
}

TEST_F(ExecutorTest, FrameRangeIsCachedAndPublishedApart) {
  RunRequest req;
  req.frames = FrameSelection::Parse("0:4");
  const auto range = Run(req);
  EXPECT_EQ(g_scale_frames, 4);
  EXPECT_EQ(range.manifest_path, root_ / "out" / "frames-0-4" / "manifest.json");
  EXPECT_EQ(Slurp(root_ / "out" / "frames-0-4" / "sum.txt"), "20");
  EXPECT_FALSE(fs::exists(root_ / "out" / "sum.txt")) << "a range run publishes only in its own folder";
  // The full run has its own keys: it neither reuses nor overwrites the range run's cache.
  const auto full = Run();
  EXPECT_EQ(Status(full, "scale"), "computed");
  EXPECT_NE(full.Find("scale")->key, range.Find("scale")->key);
  EXPECT_EQ(full.Find("scale")->summary.frames_reused, 0);
  EXPECT_EQ(g_scale_frames, 14);
  EXPECT_EQ(Slurp(root_ / "out" / "sum.txt"), "110");
  EXPECT_EQ(Slurp(root_ / "out" / "frames-0-4" / "sum.txt"), "20");
  // Both stay cached.
  EXPECT_EQ(Status(Run(req), "scale"), "reused");
  EXPECT_EQ(Status(Run(), "scale"), "reused");
  EXPECT_EQ(g_scale_frames, 14);
}

TEST_F(ExecutorTest, BadOptionsFailBeforeAnyWork) {
  doc_["stages"]["side"]["x"] = -1;
  doc_["stages"]["scale"]["factr"] = 3;
  try {
    RunSurvey(registry_, SurveyFromJson(doc_, root_ / "survey.json", nlohmann::json::object()), {});
    FAIL();
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.problems().size(), 2u) << e.what();
    EXPECT_NE(e.problems()[0].find("scale.factr: unknown option"), std::string::npos) << e.what();
    EXPECT_EQ(e.problems()[1], "side.x = -1 violates x >= 0");
  }
  EXPECT_EQ(g_list_runs, 0);
}

TEST_F(ExecutorTest, SchemaNamesPointerForUnknownAndIllTypedKeys) {
  doc_["stages"]["scale"]["factr"] = 3;
  doc_["stages"]["side"]["x"] = "three";
  doc_["outptu"] = "x";
  try {
    Survey();
    FAIL();
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/stages/scale/factr: unknown key (allowed keys: factor, skip_bad)"), std::string::npos)
        << what;
    EXPECT_NE(what.find("/outptu: unknown key"), std::string::npos) << what;
    EXPECT_NE(what.find("/stages/side/x: "), std::string::npos) << what;
    EXPECT_NE(what.find("\"three\""), std::string::npos) << what;
  }
}

TEST(JobGraph, OrderAndDownstream) {
  StageRegistry reg;
  reg.Add(std::make_unique<SumStage>());  // registered before its producers on purpose
  reg.Add(std::make_unique<ScaleStage>());
  reg.Add(std::make_unique<ListStage>());
  const auto g = JobGraph::Build(reg);
  std::vector<std::string> order;
  for (const Stage* s : g.order()) order.push_back(s->info().name);
  EXPECT_EQ(order, (std::vector<std::string>{"list", "scale", "sum"}));
  EXPECT_EQ(g.Downstream("scale"), (std::set<std::string>{"scale", "sum"}));
  EXPECT_EQ(g.Upstream("sum"), (std::set<std::string>{"list", "scale"}));
}

TEST(JobGraph, MissingProducer) {
  StageRegistry reg;
  reg.Add(std::make_unique<SumStage>());
  EXPECT_THROW(JobGraph::Build(reg), std::logic_error);
}

}  // namespace
}  // namespace rs
