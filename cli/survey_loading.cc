#include "cli/survey_loading.h"

#include "survey/survey_schema.h"

namespace rs {

SurveyFile LoadSurveyForCommand(const std::filesystem::path& path, const StageRegistry& registry) {
  return LoadSurveyFile(path, BuildSurveySchema(registry));
}

}  // namespace rs
