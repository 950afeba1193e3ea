#pragma once
// Command-line flags derived from option tables: the same registration that
// defines the survey.json key and the JSON Schema. Stage options become
// --<stage>.<option>; a table added without a prefix gives --<option>.

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <vector>

namespace rs {

class OptionTableBase;
class StageRegistry;

class OptionFlags {
 public:
  /// Adds one flag per option of `table` to `app`, in option group `group`.
  /// `skip` names options the command handles itself.
  void Add(CLI::App& app, const std::string& prefix, const OptionTableBase& table, const std::string& group,
           const std::vector<std::string>& skip = {});
  /// Every stage's options, as --<stage>.<option>.
  void AddStages(CLI::App& app, const StageRegistry& registry);
  /// The flags given, typed: {prefix: {option: value}}, or {option: value}
  /// for tables added without a prefix. Throws OptionError when a value does
  /// not parse as the option's type.
  nlohmann::json Overrides() const;

 private:
  struct Flag {
    std::string prefix, name;
    const OptionTableBase* table;
    CLI::Option* option;
  };
  std::vector<Flag> flags_;
  std::map<std::string, std::string> values_;  // flag name -> raw text (stable addresses for CLI11)
};

}  // namespace rs
