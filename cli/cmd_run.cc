// roadsurvey run SURVEY.json: runs the job graph, reusing cached stage runs.
#include <fmt/format.h>

#include "cli/command.h"
#include "cli/option_flags.h"
#include "cli/skipped_frames.h"
#include "cli/survey_loading.h"
#include "survey/executor.h"

namespace rs {

Command RunCommand() {
  return {"run", "Run a survey: every stage whose inputs or options changed, reusing the rest",
          [](CLI::App& app, const StageRegistry& registry) -> std::function<int()> {
            struct Args {
              std::string survey, output, rerun_from, only, frames = "all", progress = "auto";
              int threads = 0;
            };
            auto args = std::make_shared<Args>();
            app.add_option("survey", args->survey, "survey file (survey.json)")->required();
            app.add_option("--output", args->output, "output folder (overrides the survey file's \"output\")")
                ->check(NonEmptyFolderName());
            app.add_option("--rerun-from", args->rerun_from,
                           "recompute this stage and everything after it even if cached");
            app.add_option("--only", args->only, "run only this stage (its inputs must be cached)");
            app.add_option("--frames", args->frames, "frame range A:B (B exclusive), A:, :B or all");
            app.add_option("--threads", args->threads, "worker threads (0 = all cores)")->check(CLI::NonNegativeNumber);
            app.add_option("--progress", args->progress, "progress display")
                ->check(CLI::IsMember({"auto", "terminal", "log", "quiet"}));
            auto flags = std::make_shared<OptionFlags>();
            flags->AddStages(app, registry);
            return [args, flags, &registry] {
              const SurveyFile survey = LoadSurveyForCommand(args->survey, registry, args->output);
              RunRequest req;
              req.cli_overrides = flags->Overrides();
              // What `validate` would reject fails here, before anything is computed or written.
              if (!CheckBeforeRun(registry, survey, req.cli_overrides)) return static_cast<int>(kExitBadInput);
              if (!args->rerun_from.empty()) req.rerun_from = args->rerun_from;
              if (!args->only.empty()) req.only = args->only;
              req.frames = FrameSelection::Parse(args->frames);
              req.threads = args->threads;
              req.progress = args->progress == "terminal" ? Progress::Mode::kTerminal
                             : args->progress == "log"    ? Progress::Mode::kLog
                             : args->progress == "quiet"  ? Progress::Mode::kQuiet
                                                          : Progress::Mode::kAuto;
              const RunReport report = RunSurvey(registry, survey, req);

              fmt::print("\n{:<12} {:<13} {:>9} {:>9} {:>7} {:>8}\n", "stage", "status", "wall [s]", "computed",
                         "reused", "skipped");
              for (const auto& r : report.stages) {
                fmt::print("{:<12} {:<13} {:>9.2f} {:>9} {:>7} {:>8}\n", r.name, ToString(r.status), r.wall_s,
                           r.summary.frames_computed, r.summary.frames_reused, r.summary.frames_skipped);
                PrintSkippedFrames(r.summary.ToJson()["frames"]["skipped_frames"]);
                if (r.summary.counts.contains("headline") && r.summary.counts["headline"].is_string())
                  fmt::print("    {}\n", r.summary.counts["headline"].get<std::string>());
                if (!r.error.empty()) fmt::print("    error: {}\n", r.error);
              }
              if (!report.error.empty()) fmt::print("error: {}\n", report.error);
              fmt::print("\nOutputs in {}\n", RunFolder(survey, req.frames).string());
              for (const auto& [name, path] : report.published) fmt::print("  {}\n", name);
              fmt::print("  manifest.json (what ran, keys, counts, warnings, options)\n");
              return report.exit_code;
            };
          }};
}

}  // namespace rs
