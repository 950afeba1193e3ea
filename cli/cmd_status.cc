// roadsurvey status OUTPUT: what the last run did and what is cached.
#include <fmt/format.h>

#include "cli/command.h"
#include <nlohmann/json.hpp>

#include "formats/input_error.h"
#include "survey/atomic_file.h"
#include "survey/job_graph.h"
#include "survey/output_lock.h"

namespace rs {
namespace {

// The manifest's stages (a JSON object, so sorted by name) in pipeline order; stages this
// program does not know follow in name order.
std::vector<std::string> PipelineOrder(const StageRegistry& registry, const nlohmann::json& stages) {
  std::vector<std::string> names;
  const JobGraph graph = JobGraph::Build(registry);
  for (const Stage* stage : graph.order())
    if (stages.contains(stage->info().name)) names.push_back(stage->info().name);
  for (const auto& [name, s] : stages.items())
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  return names;
}

// A manifest left at "running" by a process that no longer exists: the run was interrupted
// (kill -9, crash, power loss) and never finished its manifest.
std::string EffectiveState(const nlohmann::json& run) {
  const std::string state = run.value("state", "?");
  if (state != "running" || !run.contains("pid")) return state;
  LockHolder writer;
  writer.pid = run.value("pid", int64_t{0});
  writer.host = run.value("host", "");
  return writer.MaybeAlive() ? state : "interrupted";
}

}  // namespace

Command StatusCommand() {
  return {"status", "Show the last run of an output folder: per stage status, key, time, counts",
          [](CLI::App& app, const StageRegistry& registry) -> std::function<int()> {
            auto output = std::make_shared<std::string>();
            app.add_option("output", *output, "a survey's output folder")->required();
            return [output, &registry] {
              namespace fs = std::filesystem;
              const fs::path output_dir = *output;
              const fs::path manifest_path = output_dir / "manifest.json";
              if (!fs::exists(manifest_path))
                throw InputError(InputLocation::File(manifest_path.string()),
                                 "no manifest: this folder has not been used as a survey output");
              const auto m = ReadJsonFile(manifest_path);
              const auto& run = m.at("run");
              const std::string state = EffectiveState(run);
              fmt::print("survey {} ({})\nlast run: {} -> {}, {}; frames {}\n", m["survey"].value("name", "?"),
                         m["survey"].value("file", "?"), run.value("started_utc", "?"), run.value("finished_utc", "-"),
                         state, run.value("frames", "all"));
              if (state == "interrupted")
                fmt::print("  the run (PID {}) ended without finishing: run it again to resume\n",
                           run.value("pid", int64_t{0}));
              else if (state == "running")
                fmt::print("  still running (PID {} on host {})\n", run.value("pid", int64_t{0}),
                           run.value("host", "?"));
              fmt::print("\n{:<12} {:<13} {:<17} {:>9} {:>9} {:>7} {:>8} {:>8}\n", "stage", "status", "key", "wall [s]",
                         "computed", "reused", "skipped", "warnings");
              const auto& stages = m.at("stages");
              for (const std::string& name : PipelineOrder(registry, stages)) {
                const auto& s = stages[name];
                const auto frames = s.value("frames", nlohmann::json::object());
                fmt::print("{:<12} {:<13} {:<17} {:>9.2f} {:>9} {:>7} {:>8} {:>8}\n", name, s.value("status", "?"),
                           s.value("key", ""), s.value("wall_s", 0.0), frames.value("computed", 0),
                           frames.value("reused", 0), frames.value("skipped", 0),
                           s.value("warnings", nlohmann::json::array()).size());
                if (s.contains("error")) fmt::print("    error: {}\n", s["error"].get<std::string>());
              }
              if (m.contains("error")) fmt::print("error: {}\n", m["error"].get<std::string>());
              // What is in the folder now: an interrupted run's manifest lists only what it
              // published before it stopped; the rest is still there from earlier runs.
              std::vector<std::string> lines;
              const JobGraph graph = JobGraph::Build(registry);
              for (const Stage* stage : graph.order())
                for (const auto& pub : stage->info().published)
                  if (fs::exists(output_dir / pub.to))
                    lines.push_back(m["published"].contains(pub.to) ? pub.to : pub.to + "  (from an earlier run)");
              if (!lines.empty()) {
                fmt::print("\npublished:\n");
                for (const auto& line : lines) fmt::print("  {}\n", line);
              }
              return state == "succeeded" || state == "running" ? kExitOk : kExitProcessing;
            };
          }};
}

}  // namespace rs
