// roadsurvey validate SURVEY.json: checks the survey file and every input up
// front, listing every problem at once with file and line.
#include <fmt/format.h>

#include "cli/command.h"
#include "cli/option_flags.h"
#include "cli/survey_loading.h"
#include "survey/executor.h"

namespace rs {

Command ValidateCommand() {
  return {"validate", "Check a survey file and all its inputs without processing; list every problem",
          [](CLI::App& app, const StageRegistry& registry) -> std::function<int()> {
            auto survey_path = std::make_shared<std::string>();
            app.add_option("survey", *survey_path, "survey file (survey.json)")->required();
            auto flags = std::make_shared<OptionFlags>();
            flags->AddStages(app, registry);
            return [survey_path, flags, &registry] {
              const SurveyFile survey = LoadSurveyForCommand(*survey_path, registry);
              const nlohmann::json options = ResolveOptions(registry, survey, flags->Overrides());
              ProblemList problems;
              for (const auto& stage : registry.stages()) {
                try {
                  stage->Validate(survey, options[stage->info().name], problems);
                } catch (const InputError& e) {
                  problems.Add(e);
                }
              }
              for (const auto& p : problems.items()) fmt::print("{}\n", p.ToString());
              fmt::print("{}: {} error(s), {} warning(s)\n", survey.path.string(), problems.ErrorCount(),
                         problems.WarningCount());
              return problems.HasErrors() ? kExitBadInput : kExitOk;
            };
          }};
}

}  // namespace rs
