#include "cli/option_flags.h"

#include <fmt/format.h>

#include <algorithm>

#include "survey/stage.h"

namespace rs {
namespace {

nlohmann::json ParseTyped(const std::string& text, const OptionSpec& spec, const std::string& flag) {
  try {
    size_t used = 0;
    switch (spec.type) {
      case OptionType::kBool:
        if (text == "true" || text == "1" || text == "on") return true;
        if (text == "false" || text == "0" || text == "off") return false;
        break;
      case OptionType::kInt: {
        const long long v = std::stoll(text, &used);
        if (used == text.size()) return v;
        break;
      }
      case OptionType::kDouble: {
        const double v = std::stod(text, &used);
        if (used == text.size()) return v;
        break;
      }
      case OptionType::kString: return text;
    }
  } catch (const std::exception&) {}
  throw OptionError(fmt::format("--{} {}: expected {}", flag, text, spec.AllowedText()));
}

}  // namespace

void OptionFlags::Add(CLI::App& app, const std::string& prefix, const OptionTableBase& table, const std::string& group,
                      const std::vector<std::string>& skip) {
  for (const auto& spec : table.specs()) {
    if (std::find(skip.begin(), skip.end(), spec.name) != skip.end()) continue;
    const std::string flag = prefix.empty() ? spec.name : prefix + "." + spec.name;
    CLI::Option* option =
        app.add_option("--" + flag, values_[flag],
                       fmt::format("{}{} ({}; default {})", spec.doc, spec.unit.empty() ? "" : " [" + spec.unit + "]",
                                   spec.AllowedText(), spec.default_value.dump()))
            ->group(group);
    flags_.push_back({prefix, spec.name, &table, option});
  }
}

void OptionFlags::AddStages(CLI::App& app, const StageRegistry& registry) {
  for (const auto& stage : registry.stages())
    Add(app, stage->info().name, stage->options(),
        fmt::format("Options of stage '{}' (override survey.json)", stage->info().name));
}

nlohmann::json OptionFlags::Overrides() const {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& f : flags_) {
    if (f.option->count() == 0) continue;
    const std::string flag = f.prefix.empty() ? f.name : f.prefix + "." + f.name;
    const nlohmann::json value = ParseTyped(values_.at(flag), *f.table->Find(f.name), flag);
    if (f.prefix.empty()) {
      out[f.name] = value;
    } else {
      out[f.prefix][f.name] = value;
    }
  }
  return out;
}

}  // namespace rs
