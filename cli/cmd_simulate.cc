// roadsurvey simulate OUT_DIR [--preset NAME] [--seed N] [--<option> V ...]:
// writes a complete simulated survey folder with exact ground truth.
#include <fmt/format.h>

#include "cli/command.h"
#include "cli/option_flags.h"
#include "sim/simulate.h"
#include "survey/progress.h"

namespace rs {

Command SimulateCommand() {
  return {"simulate", "Write a simulated stereo survey (frames, calibration, flight log, ground truth, survey.json)",
          [](CLI::App& app, const StageRegistry&) -> std::function<int()> {
            struct Args {
              std::string out_dir, preset = "demo", name, progress = "auto";
            };
            auto args = std::make_shared<Args>();
            app.add_option("out_dir", args->out_dir, "folder to write (created)")->required();
            std::string presets;
            for (const auto& p : PresetNames()) presets += (presets.empty() ? "" : ", ") + p;
            app.add_option("--preset", args->preset, "scene and flight preset: " + presets)
                ->check(CLI::IsMember(PresetNames()));
            app.add_option("--name", args->name, "survey name written into survey.json (default: the preset)");
            app.add_option("--progress", args->progress, "progress display")
                ->check(CLI::IsMember({"auto", "terminal", "log", "quiet"}));
            auto flags = std::make_shared<OptionFlags>();
            flags->Add(app, "", SimulationOptions::Table(), "Simulation options (override the preset)", {"preset"});
            return [args, flags] {
              const auto& table = SimulationOptions::Table();
              const nlohmann::json base = table.ToJson(PresetOptions(args->preset));
              const SimulationOptions options = table.FromJson(table.Merge(flags->Overrides(), "simulate", base));
              options.Check();
              Progress progress(args->progress == "terminal" ? Progress::Mode::kTerminal
                                : args->progress == "log"    ? Progress::Mode::kLog
                                : args->progress == "quiet"  ? Progress::Mode::kQuiet
                                                             : Progress::Mode::kAuto);
              progress.Start("simulate", options.num_frames, "pairs");
              const SimulationSummary summary =
                  Simulate(options, args->out_dir, [&](int done, int) { progress.Advance(done - progress.done()); });
              progress.Finish();
              WriteSurveyJson(std::filesystem::path(args->out_dir) / "survey.json",
                              args->name.empty() ? args->preset : args->name, options);
              fmt::print("{}\nSurvey folder: {}\nRun it with: roadsurvey run {}\n", summary.BriefReport(),
                         args->out_dir, (std::filesystem::path(args->out_dir) / "survey.json").string());
              return kExitOk;
            };
          }};
}

}  // namespace rs
