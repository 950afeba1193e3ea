#include "survey/executor.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <chrono>
#include <thread>

#include "survey/atomic_file.h"
#include "survey/hash.h"
#include "survey/input_key.h"
#include "survey/output_lock.h"
#include "survey/publish.h"
#include "survey/version.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr const char* kMarker = kStageMarker;

std::string UtcNow() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// The selection sets a frame-range run's keys apart from a full run's (a full run's keys do not
// change): every stage's result may depend on it, through the frames ingest lists and the
// disparity stage's temporal prior (the previous listed frame), so no cache is shared.
void AddFrameSelection(KeyHasher& h, const FrameSelection& frames) {
  if (!frames.All()) h.Add("frames").Add(frames.ToString());
}

// A complete run for this key and frame selection exists at `dir`.
bool IsComplete(const fs::path& dir, const Stage& stage, const FrameSelection& frames) {
  const fs::path marker = dir / kMarker;
  if (!fs::exists(marker)) return false;
  try {
    const auto j = ReadJsonFile(marker);
    return !stage.info().per_frame || j.value("frame_selection", std::string()) == frames.ToString();
  } catch (const std::exception&) {
    return false;  // unreadable marker: treat as incomplete and recompute
  }
}

nlohmann::json RecordJson(const StageRunRecord& r) {
  nlohmann::json j = {{"version", r.version},  {"key", r.key},       {"status", ToString(r.status)},
                      {"cached", r.cached},    {"wall_s", r.wall_s}, {"options", r.options},
                      {"inputs", r.input_keys}};
  if (r.status == StageStatus::kComputed || r.status == StageStatus::kReused || r.status == StageStatus::kFailed)
    j.update(r.summary.ToJson());
  if (!r.error.empty()) j["error"] = r.error;
  return j;
}

void WriteManifest(const fs::path& path, const SurveyFile& survey, const RunRequest& request,
                   const std::string& started, const RunReport& report, bool finished) {
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& r : report.stages) stages[r.name] = RecordJson(r);
  nlohmann::json j = {{"roadsurvey_version", kRoadsurveyVersion},
                      {"survey", {{"name", survey.name}, {"file", survey.path.string()}, {"crs", survey.crs}}},
                      {"run",
                       {{"started_utc", started},
                        {"finished_utc", finished ? UtcNow() : ""},
                        {"pid", static_cast<int64_t>(::getpid())},  // `status` tells a killed run from a live one
                        {"host", LockHolder::Self(started).host},
                        {"state", finished ? (report.exit_code == 0 ? "succeeded" : "failed") : "running"},
                        {"frames", request.frames.ToString()},
                        {"rerun_from", request.rerun_from.value_or("")},
                        {"only", request.only.value_or("")}}},
                      {"stages", stages},
                      {"published", report.published}};
  if (!report.error.empty()) j["error"] = report.error;
  WriteJsonAtomic(path, j);
}

// Takes the output folder for this run and clears what killed runs left there.
OutputLock TakeOutputFolder(const fs::path& output_dir, const std::string& started) {
  OutputLock lock = OutputLock::Acquire(output_dir, LockHolder::Self(started));
  if (const auto& previous = lock.taken_over_from())
    spdlog::warn("the previous run ({}) ended without releasing the output folder (killed?): taking it over",
                 previous->ToString());
  if (const int64_t n = RemoveOrphanTemporaries(output_dir))
    spdlog::info("removed {} unfinished temporary file(s) or folder(s) of interrupted runs", n);
  return lock;
}

// A failure outside the stages (a full disk while publishing or writing the manifest) fails the
// run (exit 1) but still lets it finish its report.
void RecordRunError(RunReport& report, const std::string& message) {
  spdlog::error("{}", message);
  if (report.error.empty()) report.error = message;
  report.exit_code = std::max(report.exit_code, 1);
}

void TryWriteManifest(const SurveyFile& survey, const RunRequest& request, const std::string& started,
                      RunReport& report, bool finished) {
  try {
    WriteManifest(report.manifest_path, survey, request, started, report, finished);
  } catch (const std::exception& e) {
    RecordRunError(report, e.what());
    if (finished) {
      try {  // record the failure itself when there is still room for it
        WriteManifest(report.manifest_path, survey, request, started, report, finished);
      } catch (const std::exception&) {}
    }
  }
}

// Publishes a stage's results under their stable names; a failure fails the stage (exit 1), not
// the cache.
void PublishStage(const StageInfo& info, const fs::path& dir, const fs::path& run_folder, StageRunRecord& rec,
                  RunReport& report) {
  for (const auto& pub : info.published) {
    const fs::path from = dir / pub.from;
    if (!fs::exists(from)) continue;
    try {
      PublishFile(from, run_folder / pub.to);
      report.published[pub.to] = from.string();
    } catch (const std::exception& e) {
      rec.error = e.what();
      rec.exit_code = std::max(rec.exit_code, 1);
      spdlog::error("{}: {}", info.name, rec.error);
    }
  }
}

}  // namespace

const char* ToString(StageStatus s) {
  switch (s) {
    case StageStatus::kComputed: return "computed";
    case StageStatus::kReused: return "reused";
    case StageStatus::kFailed: return "failed";
    case StageStatus::kBlocked: return "blocked";
    case StageStatus::kNotSelected: return "not-selected";
  }
  return "?";
}

const StageRunRecord* RunReport::Find(const std::string& name) const {
  for (const auto& r : stages)
    if (r.name == name) return &r;
  return nullptr;
}

fs::path RunFolder(const SurveyFile& survey, const FrameSelection& frames) {
  return frames.All() ? survey.output_dir : survey.output_dir / frames.FolderName();
}

fs::path StageRunDir(const SurveyFile& survey, const std::string& stage, const std::string& key) {
  return survey.output_dir / "work" / stage / key;
}

nlohmann::json ResolveOptions(const StageRegistry& registry, const SurveyFile& survey,
                              const nlohmann::json& cli_overrides) {
  std::vector<std::string> problems;
  for (const auto* source : {&survey.stage_options, &cli_overrides}) {
    for (const auto& [name, value] : source->items())
      if (!registry.Find(name)) problems.push_back(fmt::format("unknown stage '{}' in options", name));
  }
  nlohmann::json resolved = nlohmann::json::object();
  for (const auto& stage : registry.stages()) {
    const std::string& name = stage->info().name;
    try {
      nlohmann::json overrides = survey.stage_options.value(name, nlohmann::json::object());
      if (cli_overrides.contains(name)) overrides.update(cli_overrides[name]);
      resolved[name] = stage->options().Merge(overrides, name);
      stage->CheckOptions(resolved[name]);
    } catch (const OptionError& e) {
      problems.push_back(e.what());
    }
  }
  if (!problems.empty()) throw ConfigError(problems);
  return resolved;
}

std::map<std::string, std::string> ComputeKeys(const StageRegistry& registry, const JobGraph& graph,
                                               const SurveyFile& survey, const nlohmann::json& options,
                                               std::map<std::string, std::map<std::string, std::string>>* input_keys,
                                               const FrameSelection& frames) {
  const OutputExclusion output = SurveyOutputExclusion(registry, survey);
  std::map<std::string, std::string> keys;
  for (const Stage* stage : graph.order()) {
    const StageInfo& info = stage->info();
    KeyHasher h;
    h.Add("stage").Add(info.name).Add(static_cast<int64_t>(info.version)).Add(options.at(info.name).dump());
    // Only when present: the keys of stages without one stay as they were.
    if (const std::string extra = stage->ExtraKey(survey, options.at(info.name)); !extra.empty()) h.Add("extra").Add(extra);
    AddFrameSelection(h, frames);
    std::map<std::string, std::string> inputs;
    for (const auto& artifact : info.inputs)
      inputs[artifact] =
          IsSourceArtifact(artifact) ? SourceKey(survey, artifact, output) : keys.at(graph.ProducerOf(artifact));
    for (const auto& [artifact, key] : inputs) h.Add(artifact).Add(key);  // std::map: sorted, canonical
    keys[info.name] = h.Hex();
    if (input_keys) (*input_keys)[info.name] = inputs;
  }
  return keys;
}

RunReport RunSurvey(const StageRegistry& registry, const SurveyFile& survey, const RunRequest& request) {
  const JobGraph graph = JobGraph::Build(registry);
  const nlohmann::json options = ResolveOptions(registry, survey, request.cli_overrides);
  if (request.rerun_from) registry.Get(*request.rerun_from);
  if (request.only) registry.Get(*request.only);

  std::map<std::string, std::map<std::string, std::string>> input_keys;
  const auto keys = ComputeKeys(registry, graph, survey, options, &input_keys, request.frames);
  const std::set<std::string> forced =
      request.rerun_from ? graph.Downstream(*request.rerun_from) : std::set<std::string>{};
  const int threads = request.threads > 0 ? request.threads : std::max(1u, std::thread::hardware_concurrency());

  const std::string started = UtcNow();
  const OutputLock lock = TakeOutputFolder(survey.output_dir, started);
  const fs::path run_folder = RunFolder(survey, request.frames);
  fs::create_directories(run_folder);
  RunReport report;
  report.manifest_path = run_folder / "manifest.json";
  std::set<std::string> unavailable;  // stages whose outputs this run cannot provide

  for (const Stage* stage : graph.order()) {
    const StageInfo& info = stage->info();
    StageRunRecord rec;
    rec.name = info.name;
    rec.version = info.version;
    rec.key = keys.at(info.name);
    rec.options = options.at(info.name);
    rec.input_keys = input_keys.at(info.name);
    const fs::path dir = StageRunDir(survey, info.name, rec.key);
    const bool complete = IsComplete(dir, *stage, request.frames);

    std::map<std::string, fs::path> input_dirs;
    std::string blocked_by;
    for (const auto& artifact : info.inputs) {
      if (IsSourceArtifact(artifact)) continue;
      const std::string producer = graph.ProducerOf(artifact);
      if (unavailable.count(producer)) blocked_by = producer;
      input_dirs[artifact] = StageRunDir(survey, producer, keys.at(producer));
    }

    const bool selected = !request.only || *request.only == info.name;
    if (!selected) {
      rec.status = StageStatus::kNotSelected;
      rec.cached = complete;
      if (!complete) unavailable.insert(info.name);
    } else if (!blocked_by.empty()) {
      rec.status = StageStatus::kBlocked;
      rec.error = request.only
                      ? fmt::format("input from stage '{}' is not in the cache; run without --only first", blocked_by)
                      : fmt::format("not run: stage '{}' failed", blocked_by);
      rec.exit_code = request.only ? 2 : 1;
      unavailable.insert(info.name);
    } else if (complete && !forced.count(info.name)) {
      rec.status = StageStatus::kReused;
      rec.cached = true;
      const auto marker = ReadJsonFile(dir / kMarker);
      // The manifest keeps reporting what the cached run found (counts, skips, warnings);
      // this run computed nothing and took no time.
      rec.summary = StageSummary::FromJson(marker);
      rec.summary.frames_reused = rec.summary.frames_total - rec.summary.frames_skipped;
      rec.summary.frames_computed = 0;
      rec.wall_s = 0;
      spdlog::info("{}: reused (key {})", info.name, rec.key);
    } else {
      // A forced re-run computes beside the finished run and swaps in only on success:
      // nothing is lost if it fails.
      const bool swap = forced.count(info.name) && fs::exists(dir);
      const fs::path run_dir = swap ? fs::path(dir.string() + ".rerun") : dir;
      Progress progress(request.progress);
      StageContext ctx(info.name, survey, run_dir, input_dirs, request.frames, threads, progress);
      spdlog::info("{}: running (key {})", info.name, rec.key);
      const auto t0 = std::chrono::steady_clock::now();
      try {
        if (swap) fs::remove_all(run_dir);
        fs::create_directories(run_dir);  // on a full disk this fails too: a failed stage, not a crash
        stage->Run(ctx, rec.options);
        rec.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        rec.summary = ctx.summary();
        nlohmann::json marker = {{"stage", info.name},       {"version", info.version},
                                 {"key", rec.key},           {"options", rec.options},
                                 {"inputs", rec.input_keys}, {"frame_selection", request.frames.ToString()},
                                 {"wall_s", rec.wall_s},     {"finished_utc", UtcNow()}};
        marker.update(rec.summary.ToJson());
        WriteJsonAtomic(run_dir / kMarker, marker);
        if (swap) {
          const fs::path trash = dir.string() + ".old";
          fs::remove_all(trash);
          fs::rename(dir, trash);
          fs::rename(run_dir, dir);
          fs::remove_all(trash);
        }
        rec.status = StageStatus::kComputed;
        rec.cached = true;
        spdlog::info("{}: computed in {:.2f} s ({} frames computed, {} reused, {} skipped)", info.name, rec.wall_s,
                     rec.summary.frames_computed, rec.summary.frames_reused, rec.summary.frames_skipped);
      } catch (const InputError& e) {
        rec.error = e.what();
        rec.exit_code = 2;
      } catch (const OptionError& e) {
        rec.error = e.what();
        rec.exit_code = 2;
      } catch (const std::exception& e) {
        rec.error = e.what();
        rec.exit_code = 1;
      }
      if (rec.exit_code != 0) {
        rec.status = StageStatus::kFailed;
        rec.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        rec.summary = ctx.summary();
        unavailable.insert(info.name);
        spdlog::error("{}: failed: {}", info.name, rec.error);
      }
    }

    if (rec.status == StageStatus::kComputed || rec.status == StageStatus::kReused ||
        (rec.status == StageStatus::kNotSelected && rec.cached))
      PublishStage(info, dir, run_folder, rec, report);
    report.exit_code = std::max(report.exit_code, rec.exit_code);
    report.stages.push_back(std::move(rec));
    TryWriteManifest(survey, request, started, report, false);
  }
  TryWriteManifest(survey, request, started, report, true);
  return report;
}

}  // namespace rs
