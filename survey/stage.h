#pragma once
// A stage: one step of the job graph. It reads like a PDAL stage with COLMAP
// options: a name, a version, a typed Options struct registered once, declared
// input and output artifacts, and Run(ctx) returning a summary that goes into
// the manifest. See docs/architecture.md, "How to add a stage".

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "formats/frame_index.h"
#include "formats/input_error.h"
#include "survey/frame_selection.h"
#include "survey/options.h"
#include "survey/progress.h"
#include "survey/survey_file.h"

namespace rs {

/// The artifact name of the survey's own inputs (frames folder, calibration, flight log).
inline constexpr const char* kSurveyInputs = "survey.inputs";

/// The file a finished stage run leaves in its output folder, written last: its presence marks the run
/// complete; it holds the run's summary (StageSummary::ToJson), wall time and finish time.
inline constexpr const char* kStageMarker = "stage.json";

/// A file a stage publishes under a stable name at the top of the output folder.
struct PublishedFile {
  std::string from;  ///< path relative to the stage's output folder
  std::string to;    ///< path relative to the survey's output folder, e.g. "trajectory.tum"
};

/// What a stage is, independent of any run.
struct StageInfo {
  std::string name;                  ///< "disparity"; also the options key and CLI prefix
  int version = 1;                   ///< bump when outputs change for the same inputs and options
  std::string doc;                   ///< one paragraph for `roadsurvey stages`
  std::vector<std::string> inputs;   ///< artifacts consumed (kSurveyInputs or another stage's outputs)
  std::vector<std::string> outputs;  ///< artifacts produced; each lives in the stage's output folder
  std::vector<PublishedFile> published;
  bool per_frame = false;  ///< caches per frame (resumable mid-stage)
};

/// A frame a stage could not process and left out, with why (InputError message and location).
struct SkippedFrame {
  int64_t frame = 0;   ///< frame id
  std::string reason;  ///< e.g. "truncated PNG (no IEND chunk)"; also the key of skip_reasons
  std::string where;   ///< the file (and line/byte) at fault, when known
  bool operator<(const SkippedFrame& o) const { return frame < o.frame; }
};

/// Counts, warnings and timings of one stage run; goes into manifest.json.
struct StageSummary {
  nlohmann::json counts = nlohmann::json::object();     ///< e.g. {"frames": 40, "inliers_mean": 812}
  nlohmann::json timings_s = nlohmann::json::object();  ///< per step, seconds
  std::vector<std::string> warnings;
  int64_t frames_total = 0;     ///< frames selected for this run
  int64_t frames_computed = 0;  ///< computed in this run
  int64_t frames_reused = 0;    ///< found finished in the cache (resume)
  int64_t frames_skipped = 0;   ///< failed and skipped (reasons below)
  std::map<std::string, int64_t> skip_reasons;
  std::vector<SkippedFrame> skipped;  ///< every skipped frame by id (sorted in ToJson)

  nlohmann::json ToJson() const;
  /// Inverse of ToJson (reads a cached run's marker).
  static StageSummary FromJson(const nlohmann::json& j);
};

/// Result of one frame's work.
struct FrameOutcome {
  nlohmann::json counts = nlohmann::json::object();  ///< summed into the stage summary counts
  std::vector<std::string> warnings;
};

/// Everything a stage run may touch. Stages write only below out_dir().
class StageContext {
 public:
  StageContext(std::string stage_name, const SurveyFile& survey, std::filesystem::path out_dir,
               std::map<std::string, std::filesystem::path> input_dirs, FrameSelection frames, int threads,
               Progress& progress);

  const std::string& stage_name() const { return stage_name_; }
  const SurveyFile& survey() const { return survey_; }
  /// This stage run's output folder (<output>/work/<stage>/<key>/).
  const std::filesystem::path& out_dir() const { return out_dir_; }
  /// Output folder of the stage producing `artifact`.
  const std::filesystem::path& input_dir(const std::string& artifact) const;
  const FrameSelection& frame_selection() const { return frames_; }
  int threads() const { return threads_; }
  Progress& progress() { return progress_; }

  /// Committed output folder of one frame: out_dir()/frames/<id, 6 digits>.
  std::filesystem::path FrameDir(FrameId id) const;
  /// Same folder layout inside another stage's output (a per-frame input).
  static std::filesystem::path FrameDirIn(const std::filesystem::path& stage_dir, FrameId id);

  using FrameFn = std::function<FrameOutcome(const FrameRecord& frame, const std::filesystem::path& tmp_dir)>;
  /// Runs `fn` on every selected frame that has no committed folder yet, in
  /// parallel. `fn` writes into tmp_dir, which is renamed to FrameDir(id) when
  /// it returns, so a killed run resumes without redoing finished frames.
  /// With `skip_failed`, a frame whose fn throws InputError is recorded as
  /// skipped (SkipFrame) instead of failing the stage.
  void ForEachFrame(const std::vector<FrameRecord>& frames, const FrameFn& fn, bool skip_failed);

  /// Records that frame `id` was left out and why (counted, listed by id in the summary,
  /// manifest.json and `roadsurvey status`). For stages that walk frames themselves.
  void SkipFrame(FrameId id, const std::string& reason, const std::string& where = "");

  void Warn(std::string message);
  void Count(const std::string& name, double value);
  void Time(const std::string& step, double seconds);
  StageSummary& summary() { return summary_; }

 private:
  // Counts and lists a skip (no warning: a skip found in the cache was warned about when it happened).
  void RecordSkip(FrameId id, const std::string& reason, const std::string& where);

  std::string stage_name_;
  const SurveyFile& survey_;
  std::filesystem::path out_dir_;
  std::map<std::string, std::filesystem::path> input_dirs_;
  FrameSelection frames_;
  int threads_;
  Progress& progress_;
  StageSummary summary_;
  std::mutex mutex_;
};

/// How far a validation pass goes. `run` checks everything it would fail on up front
/// (kUpFront: files, formats, the flight log against the frames); `validate` also decodes
/// every image (kFull), which a run does frame by frame, skipping the bad ones.
enum class ValidationDepth { kUpFront, kFull };

/// Type-erased stage, as the job graph sees it.
class Stage {
 public:
  virtual ~Stage() = default;
  virtual const StageInfo& info() const = 0;
  virtual const OptionTableBase& options() const = 0;
  /// Parses merged options into the typed struct and runs its Check().
  /// Throws OptionError stating the rule broken.
  virtual void CheckOptions(const nlohmann::json& merged) const = 0;
  /// Checks this stage's inputs up front (`roadsurvey validate`, and `run` before computing),
  /// listing every problem once.
  virtual void Validate(const SurveyFile& survey, const nlohmann::json& merged, ValidationDepth depth,
                        ProblemList& problems) const {}
  virtual void Run(StageContext& ctx, const nlohmann::json& merged) const = 0;
  /// What the outputs depend on beyond the inputs, options and version (a model file's digest),
  /// as text for the cache key; empty = nothing.
  virtual std::string ExtraKey(const SurveyFile& survey, const nlohmann::json& merged) const { return {}; }
};

/// Base for concrete stages: Derived provides `static StageInfo Info()` and
/// `void Run(StageContext&, const Options&) const`, and may provide
/// `void ValidateInputs(const SurveyFile&, const Options&, ValidationDepth, ProblemList&) const`
/// and `std::string ExtraKeyOf(const SurveyFile&, const Options&) const`.
/// Options provides `static const OptionTable<Options>& Table()` and `void Check() const`.
template <class Derived, class Options>
class TypedStage : public Stage {
 public:
  const StageInfo& info() const override {
    static const StageInfo info = Derived::Info();
    return info;
  }
  const OptionTableBase& options() const override { return Options::Table(); }
  void CheckOptions(const nlohmann::json& merged) const override { Options::Table().FromJson(merged).Check(); }
  void Validate(const SurveyFile& survey, const nlohmann::json& merged, ValidationDepth depth,
                ProblemList& problems) const override {
    static_cast<const Derived*>(this)->ValidateInputs(survey, Options::Table().FromJson(merged), depth, problems);
  }
  void Run(StageContext& ctx, const nlohmann::json& merged) const override {
    static_cast<const Derived*>(this)->Run(ctx, Options::Table().FromJson(merged));
  }
  std::string ExtraKey(const SurveyFile& survey, const nlohmann::json& merged) const override {
    return static_cast<const Derived*>(this)->ExtraKeyOf(survey, Options::Table().FromJson(merged));
  }
  /// Default: nothing to check before running.
  void ValidateInputs(const SurveyFile&, const Options&, ValidationDepth, ProblemList&) const {}
  /// Default: the outputs depend on the inputs, options and version alone.
  std::string ExtraKeyOf(const SurveyFile&, const Options&) const { return {}; }
};

/// The stages a program knows, in registration order. No global state: the
/// program builds one and passes it down.
class StageRegistry {
 public:
  void Add(std::unique_ptr<Stage> stage);
  const Stage* Find(const std::string& name) const;
  const Stage& Get(const std::string& name) const;  ///< throws OptionError listing known stages
  const std::vector<std::unique_ptr<Stage>>& stages() const { return stages_; }

 private:
  std::vector<std::unique_ptr<Stage>> stages_;
};

}  // namespace rs
