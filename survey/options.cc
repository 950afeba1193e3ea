#include "survey/options.h"

#include <fmt/format.h>

#include <cmath>

namespace rs {
namespace {

const char* TypeName(OptionType t) {
  switch (t) {
    case OptionType::kBool: return "boolean";
    case OptionType::kInt: return "integer";
    case OptionType::kDouble: return "number";
    case OptionType::kString: return "string";
  }
  return "?";
}

std::string FormatBound(double v) {
  if (std::floor(v) == v && std::abs(v) < 1e15) return fmt::format("{}", static_cast<long long>(v));
  return fmt::format("{}", v);
}

bool HasType(const nlohmann::json& v, OptionType t) {
  switch (t) {
    case OptionType::kBool: return v.is_boolean();
    case OptionType::kInt: return v.is_number_integer();
    case OptionType::kDouble: return v.is_number();
    case OptionType::kString: return v.is_string();
  }
  return false;
}

}  // namespace

nlohmann::json OptionSpec::Schema() const {
  nlohmann::json s;
  s["type"] = TypeName(type);
  s["description"] = unit.empty() ? doc : doc + " [" + unit + "]";
  s["default"] = default_value;
  if (minimum) s[minimum_exclusive ? "exclusiveMinimum" : "minimum"] = *minimum;
  if (maximum) s[maximum_exclusive ? "exclusiveMaximum" : "maximum"] = *maximum;
  if (!choices.empty()) s["enum"] = choices;
  return s;
}

std::string OptionSpec::AllowedText() const {
  if (!choices.empty()) {
    std::string s = "one of {";
    for (size_t i = 0; i < choices.size(); ++i) s += (i ? ", " : "") + choices[i];
    return s + "}";
  }
  std::string s = TypeName(type);
  if (minimum) s += fmt::format(" {} {}", minimum_exclusive ? ">" : ">=", FormatBound(*minimum));
  if (maximum) s += fmt::format(" {} {}", maximum_exclusive ? "<" : "<=", FormatBound(*maximum));
  return s;
}

const OptionSpec* OptionTableBase::Find(const std::string& name) const {
  for (const auto& s : specs_)
    if (s.name == name) return &s;
  return nullptr;
}

nlohmann::json OptionTableBase::Defaults() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& s : specs_) j[s.name] = s.default_value;
  return j;
}

nlohmann::json OptionTableBase::Schema(const std::string& description) const {
  nlohmann::json props = nlohmann::json::object();
  for (const auto& s : specs_) props[s.name] = s.Schema();
  return {{"type", "object"}, {"description", description}, {"additionalProperties", false}, {"properties", props}};
}

nlohmann::json OptionTableBase::Merge(const nlohmann::json& overrides, const std::string& prefix,
                                      const nlohmann::json& base) const {
  nlohmann::json merged = base;
  if (overrides.is_null()) return merged;
  if (!overrides.is_object())
    throw OptionError(fmt::format("{}: expected an object of options, got {}", prefix, overrides.dump()));
  for (const auto& [key, value] : overrides.items()) {
    const OptionSpec* spec = Find(key);
    if (!spec) {
      std::string known;
      for (const auto& s : specs_) known += (known.empty() ? "" : ", ") + s.name;
      throw OptionError(fmt::format("{}.{}: unknown option (known: {})", prefix, key, known));
    }
    if (!HasType(value, spec->type))
      throw OptionError(fmt::format("{}.{} = {}: expected {}", prefix, key, value.dump(), spec->AllowedText()));
    if (!spec->choices.empty() &&
        std::find(spec->choices.begin(), spec->choices.end(), value.get<std::string>()) == spec->choices.end())
      throw OptionError(fmt::format("{}.{} = {}: expected {}", prefix, key, value.dump(), spec->AllowedText()));
    if (value.is_number()) {
      const double v = value.get<double>();
      const bool below = spec->minimum && (spec->minimum_exclusive ? v <= *spec->minimum : v < *spec->minimum);
      const bool above = spec->maximum && (spec->maximum_exclusive ? v >= *spec->maximum : v > *spec->maximum);
      if (below || above)
        throw OptionError(fmt::format("{}.{} = {}: expected {}", prefix, key, value.dump(), spec->AllowedText()));
    }
    // Keep integers integral and doubles floating so canonical JSON (and cache keys) do not
    // depend on whether the user wrote 2 or 2.0.
    merged[key] = spec->type == OptionType::kDouble ? nlohmann::json(value.get<double>()) : value;
  }
  return merged;
}

std::string RuleViolation(const std::string& stage, const std::string& name, const nlohmann::json& value,
                          const std::string& rule, const std::string& context) {
  std::string s = fmt::format("{}.{} = {} violates {}", stage, name, value.dump(), rule);
  if (!context.empty()) s += " (" + context + ")";
  return s;
}

}  // namespace rs
