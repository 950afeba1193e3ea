#include "survey/path_variables.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <optional>

#include "survey/survey_file.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

// A temporary folder standing in for the data folder, removed afterwards.
class PathVariables : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("rs_path_variables_" + std::to_string(::getpid()));
    fs::create_directories(root_ / "data" / "kitti");
    if (const char* env = std::getenv(kDataVariable)) saved_ = env;
  }
  void TearDown() override {
    if (saved_)
      ::setenv(kDataVariable, saved_->c_str(), 1);
    else
      ::unsetenv(kDataVariable);
    fs::remove_all(root_);
  }
  DataRoot Root(const fs::path& folder) { return {folder, "test"}; }

  fs::path root_;
  std::optional<std::string> saved_;
};

TEST_F(PathVariables, Nominal) {
  const auto where = InputLocation::Line("survey.json", 4, 20);
  EXPECT_EQ(ExpandPathVariables("${ROADSURVEY_DATA}/kitti", Root(root_ / "data"), where),
            (root_ / "data").string() + "/kitti");
  EXPECT_EQ(ExpandPathVariables("frames", Root(root_ / "absent"), where), "frames")
      << "a path without the variable needs no data folder";
  EXPECT_EQ(ExpandPathVariables("/x/$HOME/{y}", Root(root_ / "absent"), where), "/x/$HOME/{y}")
      << "only ${...} is a variable";
}

TEST_F(PathVariables, MissingFolderNamesTheInputLineAndTheVariable) {
  try {
    ExpandPathVariables("${ROADSURVEY_DATA}/kitti", Root(root_ / "absent"), InputLocation::Line("survey.json", 7, 15));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("survey.json:7:15: ", 0), 0u) << what;
    EXPECT_NE(what.find((root_ / "absent").string()), std::string::npos) << what;
    EXPECT_NE(what.find("Set ROADSURVEY_DATA"), std::string::npos) << what;
  }
}

TEST_F(PathVariables, UnknownVariable) {
  try {
    ExpandPathVariables("${HOME}/data", Root(root_ / "data"), InputLocation::File("survey.json"));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown variable ${HOME}"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ExpandPathVariables("${ROADSURVEY_DATA", Root(root_ / "data"), InputLocation::File("s.json")),
               InputError);
}

TEST_F(PathVariables, EnvironmentOverridesTheDefault) {
  ::setenv(kDataVariable, (root_ / "data").c_str(), 1);
  EXPECT_EQ(CurrentDataRoot().folder, root_ / "data");
  ::setenv(kDataVariable, "", 1);
  EXPECT_EQ(CurrentDataRoot().folder.filename(), "data") << "empty = unset: the default ../shared/data";
  EXPECT_EQ(CurrentDataRoot().folder.parent_path().filename(), "shared");
  ::unsetenv(kDataVariable);
  EXPECT_NE(CurrentDataRoot().origin.find("default"), std::string::npos);
}

// The survey loader expands input paths and locates a failure at the path's line in survey.json.
TEST_F(PathVariables, SurveyFileExpandsInputPaths) {
  const fs::path survey = root_ / "survey.json";
  std::ofstream(survey) << "{\n  \"name\": \"t\",\n  \"inputs\": {\n"
                           "    \"frames\": {\"path\": \"${ROADSURVEY_DATA}/kitti\"},\n"
                           "    \"calibration\": {\"path\": \"calib.txt\"}\n  },\n  \"output\": \"out\"\n}\n";
  ::setenv(kDataVariable, (root_ / "data").c_str(), 1);
  const SurveyFile s = LoadSurveyFile(survey, nlohmann::json::object());
  EXPECT_EQ(*s.InputPath("frames"), root_ / "data" / "kitti");
  EXPECT_EQ(*s.InputPath("calibration"), root_ / "calib.txt") << "other paths stay relative to survey.json";
  EXPECT_EQ(s.output_dir, root_ / "out");

  ::setenv(kDataVariable, (root_ / "absent").c_str(), 1);
  try {
    LoadSurveyFile(survey, nlohmann::json::object());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 4);
    EXPECT_EQ(e.where().column, 24);
    EXPECT_EQ(e.where().path, survey.string());
  }
}

}  // namespace
}  // namespace rs
