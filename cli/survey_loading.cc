#include "cli/survey_loading.h"

#include <fmt/format.h>

#include "survey/executor.h"
#include "survey/survey_schema.h"
#include "survey/validation.h"

namespace rs {

SurveyFile LoadSurveyForCommand(const std::filesystem::path& path, const StageRegistry& registry,
                                const std::string& output) {
  SurveyFile survey = LoadSurveyFile(path, BuildSurveySchema(registry));
  if (!output.empty()) survey.output_dir = std::filesystem::absolute(output);
  return survey;
}

CLI::Validator NonEmptyFolderName() {
  return CLI::Validator(
      [](std::string& dir) {
        return dir.empty() ? std::string("--output must name a folder (an empty path is not one)") : std::string();
      },
      "DIR");
}

bool CheckBeforeRun(const StageRegistry& registry, const SurveyFile& survey, const nlohmann::json& cli_overrides) {
  const nlohmann::json options = ResolveOptions(registry, survey, cli_overrides);
  const ProblemList problems = ValidateSurvey(registry, survey, options, ValidationDepth::kUpFront);
  if (!problems.HasErrors()) return true;
  for (const auto& p : problems.items()) fmt::print(stderr, "{}\n", p.ToString());
  fmt::print(stderr, "{}: {} error(s), {} warning(s): nothing was run (`roadsurvey validate` lists the same)\n",
             survey.path.string(), problems.ErrorCount(), problems.WarningCount());
  return false;
}

}  // namespace rs
