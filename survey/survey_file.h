#pragma once
// survey.json: what to process, where to write, and per-stage options.
// Validated against the JSON Schema built from the stage registry
// (schemas/survey.schema.json); unknown keys are errors.

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace rs {

/// A survey file that breaks the schema. Lists every problem found, each as
/// "<file>: <json pointer>: <what is wrong> (allowed: ...)".
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(std::vector<std::string> problems);
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

/// A loaded, schema-valid survey file. Relative paths resolve against the
/// folder holding survey.json; `${ROADSURVEY_DATA}` in an input path is
/// already expanded (survey/path_variables.h).
struct SurveyFile {
  std::filesystem::path path;        ///< absolute path of survey.json
  std::string name;                  ///< survey name
  nlohmann::json inputs;             ///< the "inputs" object as validated, path variables expanded
  std::filesystem::path output_dir;  ///< absolute output folder
  std::string crs;                   ///< output CRS: "utm", "enu" or "EPSG:<code>"
  nlohmann::json stage_options = nlohmann::json::object();  ///< "stages" object: stage -> overrides

  std::filesystem::path BaseDir() const { return path.parent_path(); }
  std::filesystem::path Resolve(const std::filesystem::path& p) const;
  /// inputs.<name>.path resolved, or nothing when that input is absent.
  std::optional<std::filesystem::path> InputPath(const std::string& name) const;
};

/// Validates `doc` against `schema` and returns every violation as
/// "<pointer>: <message>" (empty when valid).
std::vector<std::string> ValidateAgainstSchema(const nlohmann::json& doc, const nlohmann::json& schema);

/// Loads and validates a survey file. Throws InputError for unreadable or
/// malformed JSON (with line:column) or an input path whose variable cannot be
/// expanded (at the path's line:column), and ConfigError for schema violations.
SurveyFile LoadSurveyFile(const std::filesystem::path& path, const nlohmann::json& schema);

/// The same, from an already parsed document (path gives the base folder).
SurveyFile SurveyFromJson(const nlohmann::json& doc, const std::filesystem::path& path, const nlohmann::json& schema);

}  // namespace rs
