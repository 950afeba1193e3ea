// roadsurvey schema: prints the survey.json JSON Schema built from the registry
// (schemas/survey.schema.json is this output; a test keeps them equal).
#include <fmt/format.h>

#include "cli/command.h"
#include "survey/survey_schema.h"

namespace rs {

Command SchemaCommand() {
  return {"schema", "Print the JSON Schema of survey.json (schemas/survey.schema.json)",
          [](CLI::App&, const StageRegistry& registry) -> std::function<int()> {
            return [&registry] {
              fmt::print("{}\n", BuildSurveySchema(registry).dump(2));
              return kExitOk;
            };
          }};
}

}  // namespace rs
