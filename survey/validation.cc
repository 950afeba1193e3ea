#include "survey/validation.h"

namespace rs {
namespace fs = std::filesystem;

void CheckOutputFolder(const fs::path& output_dir, ProblemList& problems) {
  std::error_code ec;
  for (fs::path p = output_dir; !p.empty(); p = p.parent_path()) {
    const auto status = fs::status(p, ec);
    if (fs::exists(status) && !fs::is_directory(status)) {
      problems.Error(InputLocation::File(p.string()),
                     p == output_dir ? "the output folder is a file: name a folder (\"output\" or --output)"
                                     : "a file where the output folder " + output_dir.string() + " needs a folder");
      return;
    }
    if (p == p.parent_path()) break;
  }
}

ProblemList ValidateSurvey(const StageRegistry& registry, const SurveyFile& survey, const nlohmann::json& options,
                           ValidationDepth depth) {
  ProblemList problems;
  CheckOutputFolder(survey.output_dir, problems);
  for (const auto& stage : registry.stages()) {
    try {
      stage->Validate(survey, options.at(stage->info().name), depth, problems);
    } catch (const InputError& e) {
      problems.Add(e);
    }
  }
  return problems;
}

}  // namespace rs
