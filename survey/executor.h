#pragma once
// Runs the job graph for a survey: resolves options, computes cache keys,
// reuses finished stage runs, runs the rest, publishes stable outputs and
// keeps <output>/manifest.json current after every stage.
//
// Cache layout: <output>/work/<stage>/<key>/ with stage.json written last
// (its presence marks the run complete). key = hash(stage name, version,
// canonical options JSON, keys of its inputs).

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "survey/frame_selection.h"
#include "survey/job_graph.h"
#include "survey/progress.h"
#include "survey/stage.h"
#include "survey/survey_file.h"

namespace rs {

/// How to run (from the command line).
struct RunRequest {
  nlohmann::json cli_overrides = nlohmann::json::object();  ///< stage -> {option: value}, over survey.json
  std::optional<std::string> rerun_from;                    ///< recompute this stage and its dependents even if cached
  std::optional<std::string> only;                          ///< run this stage alone; its inputs must be cached
  FrameSelection frames;                                    ///< --frames A:B
  int threads = 0;                                          ///< 0 = all cores
  Progress::Mode progress = Progress::Mode::kAuto;
};

enum class StageStatus { kComputed, kReused, kFailed, kBlocked, kNotSelected };
const char* ToString(StageStatus s);

/// What happened to one stage in a run.
struct StageRunRecord {
  std::string name;
  int version = 0;
  std::string key;
  StageStatus status = StageStatus::kNotSelected;
  bool cached = false;  ///< a complete run with this key exists on disk (after this run)
  double wall_s = 0;
  StageSummary summary;
  nlohmann::json options;
  std::map<std::string, std::string> input_keys;
  std::string error;
  int exit_code = 0;  ///< 2 bad input/options, 1 processing failure
};

struct RunReport {
  std::vector<StageRunRecord> stages;
  std::map<std::string, std::string> published;  ///< top-level name -> cache path
  std::filesystem::path manifest_path;
  int exit_code = 0;  ///< 0 ok, 1 processing failure, 2 bad input
  std::string error;  ///< a failure outside the stages (publishing, the manifest), exit code 1
  const StageRunRecord* Find(const std::string& name) const;
};

/// Effective options of every stage: defaults <- survey.json <- command line.
/// Throws ConfigError listing every unknown key, ill-typed value and broken rule.
nlohmann::json ResolveOptions(const StageRegistry& registry, const SurveyFile& survey,
                              const nlohmann::json& cli_overrides);

/// Cache keys of every stage for these options (same for every selection of frames).
std::map<std::string, std::string> ComputeKeys(
    const StageRegistry& registry, const JobGraph& graph, const SurveyFile& survey, const nlohmann::json& options,
    std::map<std::string, std::map<std::string, std::string>>* input_keys = nullptr);

/// Runs the survey. Throws ConfigError/OptionError before any work on bad
/// options; stage failures are reported in the RunReport (and manifest), and
/// independent branches still run.
RunReport RunSurvey(const StageRegistry& registry, const SurveyFile& survey, const RunRequest& request);

/// Folder of a stage run in the cache.
std::filesystem::path StageRunDir(const SurveyFile& survey, const std::string& stage, const std::string& key);

}  // namespace rs
