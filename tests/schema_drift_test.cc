// schemas/survey.schema.json is generated from the stage registry (`roadsurvey
// schema`); this test fails when the committed file drifts from the code.
#include <gtest/gtest.h>

#include <fstream>

#include "cli/command.h"
#include "survey/stage.h"
#include "survey/survey_schema.h"

namespace rs {
namespace {

TEST(SchemaDrift, CommittedSchemaMatchesRegistry) {
  StageRegistry registry;
  RegisterBuiltinStages(registry);
  const auto generated = BuildSurveySchema(registry);
  std::ifstream in(std::string(ROADSURVEY_SOURCE_DIR) + "/schemas/survey.schema.json");
  ASSERT_TRUE(in) << "schemas/survey.schema.json missing: roadsurvey schema > schemas/survey.schema.json";
  const auto committed = nlohmann::json::parse(in);
  EXPECT_EQ(committed, generated) << "schemas/survey.schema.json is stale: regenerate it with "
                                     "`roadsurvey schema > schemas/survey.schema.json`";
}

TEST(SchemaDrift, EveryOptionIsDocumented) {
  StageRegistry registry;
  RegisterBuiltinStages(registry);
  for (const auto& stage : registry.stages()) {
    const std::string page = std::string(ROADSURVEY_SOURCE_DIR) + "/docs/stages/" + stage->info().name + ".md";
    std::ifstream in(page);
    ASSERT_TRUE(in) << page << " missing";
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    for (const auto& spec : stage->options().specs())
      EXPECT_NE(text.find("`" + spec.name + "`"), std::string::npos)
          << page << " does not document option " << spec.name << " (regenerate its table with `roadsurvey stages "
          << stage->info().name << " --markdown`)";
  }
}

}  // namespace
}  // namespace rs
