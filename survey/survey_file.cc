#include "survey/survey_file.h"

#include <fmt/format.h>
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validator.hpp>

#include <fstream>
#include <sstream>

#include "survey/atomic_file.h"
#include "survey/path_variables.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

std::string JoinProblems(const std::vector<std::string>& problems) {
  std::string s = fmt::format("{} problem(s) in survey file:", problems.size());
  for (const auto& p : problems) s += "\n  " + p;
  return s;
}

// valijson context ["<root>", "[stages]", "[disparity]"] -> "/stages/disparity".
std::string ContextToPointer(const std::vector<std::string>& context) {
  std::string pointer;
  for (const auto& c : context) {
    if (c == "<root>") continue;
    std::string token = c;
    if (token.size() >= 2 && token.front() == '[' && token.back() == ']') token = token.substr(1, token.size() - 2);
    // RFC 6901 escaping.
    std::string escaped;
    for (char ch : token) escaped += ch == '~' ? "~0" : ch == '/' ? "~1" : std::string(1, ch);
    pointer += "/" + escaped;
  }
  return pointer.empty() ? "/" : pointer;
}

// The schema node describing the document node at `pointer`, or null when
// the pointer leaves the schema's declared properties.
const nlohmann::json* SchemaNodeAt(const nlohmann::json& schema, const std::string& pointer) {
  const nlohmann::json* node = &schema;
  std::string rest = pointer.size() > 1 ? pointer.substr(1) : "";
  while (!rest.empty()) {
    const auto slash = rest.find('/');
    const std::string token = rest.substr(0, slash);
    if (!node->contains("properties") || !(*node)["properties"].contains(token)) return nullptr;
    node = &(*node)["properties"][token];
    rest = slash == std::string::npos ? "" : rest.substr(slash + 1);
  }
  return node;
}

// What the schema allows at `pointer`, in words, for error messages.
std::string AllowedAt(const nlohmann::json& schema, const std::string& pointer) {
  const nlohmann::json* node = SchemaNodeAt(schema, pointer);
  if (!node) return "";
  std::string allowed;
  if (node->contains("enum")) {
    for (const auto& v : (*node)["enum"]) allowed += (allowed.empty() ? "" : ", ") + v.dump();
    return "one of " + allowed;
  }
  if (node->contains("type")) allowed = (*node)["type"].dump();
  for (const char* k : {"minimum", "exclusiveMinimum", "maximum", "exclusiveMaximum", "pattern"}) {
    if (node->contains(k)) allowed += fmt::format(", {} {}", k, (*node)[k].dump());
  }
  return allowed;
}

std::string KnownKeys(const nlohmann::json& schema, const std::string& pointer) {
  const nlohmann::json* node = SchemaNodeAt(schema, pointer);
  std::string keys;
  if (node && node->contains("properties"))
    for (const auto& [k, v] : (*node)["properties"].items()) keys += (keys.empty() ? "" : ", ") + k;
  return keys;
}

// Where `value` (a JSON string) is written in the survey file, as file:line:column; the file alone when it cannot
// be read (a document built in memory) or the text is not found.
InputLocation LocateString(const fs::path& file, const std::string& value) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return InputLocation::File(file.string());
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  const size_t at = text.find(nlohmann::json(value).dump());
  if (at == std::string::npos) return InputLocation::File(file.string());
  int64_t line = 1, column = 1;
  for (size_t i = 0; i < at; ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return InputLocation::Line(file.string(), line, column);
}

}  // namespace

ConfigError::ConfigError(std::vector<std::string> problems)
    : std::runtime_error(JoinProblems(problems)), problems_(std::move(problems)) {}

fs::path SurveyFile::Resolve(const fs::path& p) const {
  return p.is_absolute() ? p.lexically_normal() : (BaseDir() / p).lexically_normal();
}

std::optional<fs::path> SurveyFile::InputPath(const std::string& name) const {
  if (!inputs.contains(name) || !inputs[name].contains("path")) return std::nullopt;
  return Resolve(inputs[name]["path"].get<std::string>());
}

std::vector<std::string> ValidateAgainstSchema(const nlohmann::json& doc, const nlohmann::json& schema) {
  valijson::Schema parsed;
  valijson::SchemaParser parser;
  valijson::adapters::NlohmannJsonAdapter schema_adapter(schema);
  parser.populateSchema(schema_adapter, parsed);

  valijson::Validator validator;
  valijson::ValidationResults results;
  valijson::adapters::NlohmannJsonAdapter doc_adapter(doc);
  if (validator.validate(parsed, doc_adapter, &results)) return {};

  std::vector<std::string> problems;
  valijson::ValidationResults::Error error;
  while (results.popError(error)) {
    const std::string pointer = ContextToPointer(error.context);
    const std::string& d = error.description;
    // valijson also reports each failing ancestor ("Failed to validate against schema associated with
    // property name 'stages'"); the leaf errors already say everything.
    if (d.rfind("Failed to validate against schema associated with property", 0) == 0) continue;
    if (d.rfind("Failed to validate item", 0) == 0) continue;
    const std::string unknown_marker = "constraints: '";
    if (const auto pos = d.find(unknown_marker); pos != std::string::npos) {
      const std::string key = d.substr(pos + unknown_marker.size(), d.size() - pos - unknown_marker.size() - 2);
      const std::string known = KnownKeys(schema, pointer);
      problems.push_back(
          fmt::format("{}{}{}: unknown key (allowed keys: {})", pointer == "/" ? "" : pointer, "/", key, known));
      continue;
    }
    const nlohmann::json::json_pointer jp(pointer == "/" ? "" : pointer);
    const std::string value = doc.contains(jp) ? doc.at(jp).dump() : "(missing)";
    const std::string allowed = AllowedAt(schema, pointer);
    problems.push_back(
        fmt::format("{}: {} (value {}{})", pointer, d, value, allowed.empty() ? "" : "; allowed: " + allowed));
  }
  return problems;
}

SurveyFile SurveyFromJson(const nlohmann::json& doc, const fs::path& path, const nlohmann::json& schema) {
  auto problems = ValidateAgainstSchema(doc, schema);
  if (!problems.empty()) {
    for (auto& p : problems) p = path.string() + ": " + p;
    throw ConfigError(std::move(problems));
  }
  SurveyFile s;
  s.path = fs::absolute(path).lexically_normal();
  s.name = doc.at("name").get<std::string>();
  s.inputs = doc.at("inputs");
  // ${ROADSURVEY_DATA} in input paths (docs/survey-file.md); the root is looked up only when some path uses it.
  for (auto& item : s.inputs.items()) {
    auto& input = item.value();
    if (!input.contains("path")) continue;
    const std::string value = input["path"].get<std::string>();
    if (value.find("${") == std::string::npos) continue;
    input["path"] = ExpandPathVariables(value, CurrentDataRoot(), LocateString(s.path, value));
  }
  s.output_dir = s.Resolve(doc.at("output").get<std::string>());
  s.crs = doc.value("crs", std::string("utm"));
  s.stage_options = doc.value("stages", nlohmann::json::object());
  return s;
}

SurveyFile LoadSurveyFile(const fs::path& path, const nlohmann::json& schema) {
  return SurveyFromJson(ReadJsonFile(path), path, schema);
}

}  // namespace rs
