// roadsurvey validate SURVEY.json...: checks survey files and every input up
// front, listing every problem at once with file and line.
#include <fmt/format.h>

#include "cli/command.h"
#include "cli/option_flags.h"
#include "cli/survey_loading.h"
#include "survey/executor.h"
#include "survey/validation.h"

namespace rs {
namespace {

// Validates one survey file; returns whether it has errors. A file that cannot be loaded (bad JSON, schema,
// path variable, option) is one error, printed like the others.
bool ValidateOne(const std::string& survey_path, const std::string& output, const StageRegistry& registry,
                 const nlohmann::json& overrides) {
  try {
    const SurveyFile survey = LoadSurveyForCommand(survey_path, registry, output);
    const nlohmann::json options = ResolveOptions(registry, survey, overrides);
    const ProblemList problems = ValidateSurvey(registry, survey, options, ValidationDepth::kFull);
    for (const auto& p : problems.items()) fmt::print("{}\n", p.ToString());
    fmt::print("{}: {} error(s), {} warning(s)\n", survey.path.string(), problems.ErrorCount(),
               problems.WarningCount());
    return problems.HasErrors();
  } catch (const ConfigError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
  } catch (const InputError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
  } catch (const OptionError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
  }
  fmt::print(stderr, "{}: cannot be loaded\n", survey_path);
  return true;
}

}  // namespace

Command ValidateCommand() {
  return {"validate", "Check survey files and all their inputs without processing; list every problem",
          [](CLI::App& app, const StageRegistry& registry) -> std::function<int()> {
            auto survey_paths = std::make_shared<std::vector<std::string>>();
            app.add_option("survey", *survey_paths, "survey file(s) (survey.json), each checked in turn")->required();
            auto output = std::make_shared<std::string>();
            app.add_option("--output", *output, "output folder to check (as `run --output`; overrides \"output\")")
                ->check(NonEmptyFolderName());
            auto flags = std::make_shared<OptionFlags>();
            flags->AddStages(app, registry);
            return [survey_paths, output, flags, &registry] {
              const nlohmann::json overrides = flags->Overrides();
              int with_errors = 0;
              for (const auto& path : *survey_paths) with_errors += ValidateOne(path, *output, registry, overrides);
              if (survey_paths->size() > 1)
                fmt::print("{} survey file(s), {} with errors\n", survey_paths->size(), with_errors);
              return with_errors > 0 ? kExitBadInput : kExitOk;
            };
          }};
}

}  // namespace rs
