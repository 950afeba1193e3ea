// roadsurvey status OUTPUT: what the last run did and what is cached.
#include <fmt/format.h>

#include "cli/command.h"
#include "cli/skipped_frames.h"
#include <nlohmann/json.hpp>

#include "formats/input_error.h"
#include "survey/atomic_file.h"

namespace rs {

Command StatusCommand() {
  return {"status", "Show the last run of an output folder: per stage status, key, time, counts",
          [](CLI::App& app, const StageRegistry&) -> std::function<int()> {
            auto output = std::make_shared<std::string>();
            app.add_option("output", *output, "a survey's output folder")->required();
            return [output] {
              const std::filesystem::path manifest_path = std::filesystem::path(*output) / "manifest.json";
              if (!std::filesystem::exists(manifest_path))
                throw InputError(InputLocation::File(manifest_path.string()),
                                 "no manifest: this folder has not been used as a survey output");
              const auto m = ReadJsonFile(manifest_path);
              const auto& run = m.at("run");
              fmt::print("survey {} ({})\nlast run: {} -> {}, {}; frames {}\n\n", m["survey"].value("name", "?"),
                         m["survey"].value("file", "?"), run.value("started_utc", "?"), run.value("finished_utc", "-"),
                         run.value("state", "?"), run.value("frames", "all"));
              fmt::print("{:<12} {:<13} {:<17} {:>9} {:>9} {:>7} {:>8} {:>8}\n", "stage", "status", "key", "wall [s]",
                         "computed", "reused", "skipped", "warnings");
              for (const auto& [name, s] : m.at("stages").items()) {
                const auto frames = s.value("frames", nlohmann::json::object());
                fmt::print("{:<12} {:<13} {:<17} {:>9.2f} {:>9} {:>7} {:>8} {:>8}\n", name, s.value("status", "?"),
                           s.value("key", ""), s.value("wall_s", 0.0), frames.value("computed", 0),
                           frames.value("reused", 0), frames.value("skipped", 0),
                           s.value("warnings", nlohmann::json::array()).size());
                PrintSkippedFrames(frames.value("skipped_frames", nlohmann::json::array()));
                if (s.contains("error")) fmt::print("    error: {}\n", s["error"].get<std::string>());
              }
              if (!m["published"].empty()) {
                fmt::print("\npublished:\n");
                for (const auto& [name, from] : m["published"].items()) fmt::print("  {}\n", name);
              }
              return run.value("state", "") == "failed" ? kExitProcessing : kExitOk;
            };
          }};
}

}  // namespace rs
