#pragma once
// One registration per option drives: the survey.json key, the CLI flag
// (--<stage>.<name>), the JSON Schema in schemas/, and `roadsurvey stages` help.
//
//   struct Options {
//     int max_disparity = 64;  ///< widest disparity searched, px
//     void Check() const;      // cross-field rules; throws OptionError
//     static const OptionTable<Options>& Table();
//   };
//   const OptionTable<Options>& Options::Table() {
//     static const auto table = OptionTable<Options>()
//         .Add("max_disparity", &Options::max_disparity, "widest disparity searched, px").Min(1);
//     return table;
//   }

#include <nlohmann/json.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace rs {

/// An option value or combination that breaks a rule. The message states the
/// rule: "disparity.p2 = 5 violates p2 > p1 (p1 = 8)".
class OptionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class OptionType { kBool, kInt, kDouble, kString };

/// Description of one option, independent of the struct it lives in.
struct OptionSpec {
  std::string name;
  std::string doc;
  OptionType type = OptionType::kInt;
  nlohmann::json default_value;
  std::optional<double> minimum, maximum;  // inclusive unless *_exclusive
  bool minimum_exclusive = false, maximum_exclusive = false;
  std::vector<std::string> choices;  // non-empty: string must be one of these
  std::string unit;                  // shown in docs, e.g. "px", "m", "s"

  /// JSON Schema fragment for this option.
  nlohmann::json Schema() const;
  /// "int >= 1", "one of {sgm, gpt-sgm}", ...: the allowed values in words.
  std::string AllowedText() const;
};

/// Type-erased view of an option table, used by the executor, schema and CLI.
class OptionTableBase {
 public:
  virtual ~OptionTableBase() = default;
  const std::vector<OptionSpec>& specs() const { return specs_; }
  const OptionSpec* Find(const std::string& name) const;
  /// Every option at its default value.
  nlohmann::json Defaults() const;
  /// JSON Schema object (additionalProperties false) for this table.
  nlohmann::json Schema(const std::string& description) const;
  /// Defaults overlaid with `overrides`; unknown keys and ill-typed or
  /// out-of-range values throw OptionError naming `prefix.key`.
  nlohmann::json Merge(const nlohmann::json& overrides, const std::string& prefix) const {
    return Merge(overrides, prefix, Defaults());
  }
  /// The same over another complete base (e.g. a preset's values).
  nlohmann::json Merge(const nlohmann::json& overrides, const std::string& prefix, const nlohmann::json& base) const;

 protected:
  std::vector<OptionSpec> specs_;
};

/// Registration of the fields of one plain options struct.
template <class Options>
class OptionTable : public OptionTableBase {
 public:
  template <class T>
  OptionTable& Add(std::string name, T Options::*field, std::string doc, std::string unit = "") {
    OptionSpec spec;
    spec.name = std::move(name);
    spec.doc = std::move(doc);
    spec.unit = std::move(unit);
    if constexpr (std::is_same_v<T, bool>) {
      spec.type = OptionType::kBool;
    } else if constexpr (std::is_integral_v<T>) {
      spec.type = OptionType::kInt;
    } else if constexpr (std::is_floating_point_v<T>) {
      spec.type = OptionType::kDouble;
    } else {
      static_assert(std::is_same_v<T, std::string>, "options are bool, integer, floating point or string");
      spec.type = OptionType::kString;
    }
    spec.default_value = Options{}.*field;
    specs_.push_back(std::move(spec));
    getters_.push_back([field](const Options& o) { return nlohmann::json(o.*field); });
    setters_.push_back([field](Options& o, const nlohmann::json& j) { o.*field = j.get<T>(); });
    return *this;
  }
  /// An enum registered by its names: the schema lists them, JSON and CLI use them.
  template <class E>
  OptionTable& AddEnum(std::string name, E Options::*field, std::vector<std::pair<std::string, E>> values,
                       std::string doc) {
    OptionSpec spec;
    spec.name = std::move(name);
    spec.doc = std::move(doc);
    spec.type = OptionType::kString;
    for (const auto& [text, value] : values) spec.choices.push_back(text);
    const E def = Options{}.*field;
    for (const auto& [text, value] : values)
      if (value == def) spec.default_value = text;
    specs_.push_back(std::move(spec));
    getters_.push_back([field, values](const Options& o) {
      for (const auto& [text, value] : values)
        if (value == o.*field) return nlohmann::json(text);
      return nlohmann::json();
    });
    setters_.push_back([field, values](Options& o, const nlohmann::json& j) {
      for (const auto& [text, value] : values)
        if (text == j.get<std::string>()) o.*field = value;
    });
    return *this;
  }

  /// Every option of a nested struct, as "<prefix>.<name>" (or "<name>" for an
  /// empty prefix): one registration per
  /// field even when a stage's options are assembled from algorithm structs.
  template <class Sub>
  OptionTable& Include(const std::string& prefix, Sub Options::*member, const OptionTable<Sub>& sub) {
    const Options defaults{};
    for (size_t i = 0; i < sub.specs().size(); ++i) {
      OptionSpec spec = sub.specs()[i];
      spec.name = prefix.empty() ? spec.name : prefix + "." + spec.name;
      spec.default_value = sub.GetAt(defaults.*member, i);
      specs_.push_back(std::move(spec));
      getters_.push_back([member, &sub, i](const Options& o) { return sub.GetAt(o.*member, i); });
      setters_.push_back([member, &sub, i](Options& o, const nlohmann::json& j) { sub.SetAt(o.*member, i, j); });
    }
    return *this;
  }

  nlohmann::json GetAt(const Options& o, size_t i) const { return getters_[i](o); }
  void SetAt(Options& o, size_t i, const nlohmann::json& j) const { setters_[i](o, j); }

  OptionTable& Min(double v) {
    specs_.back().minimum = v;
    return *this;
  }
  OptionTable& Max(double v) {
    specs_.back().maximum = v;
    return *this;
  }
  OptionTable& Above(double v) {
    specs_.back().minimum = v;
    specs_.back().minimum_exclusive = true;
    return *this;
  }
  OptionTable& Below(double v) {
    specs_.back().maximum = v;
    specs_.back().maximum_exclusive = true;
    return *this;
  }
  OptionTable& OneOf(std::vector<std::string> choices) {
    specs_.back().choices = std::move(choices);
    return *this;
  }

  /// Typed options from a complete (merged) JSON object.
  Options FromJson(const nlohmann::json& j) const {
    Options o;
    for (size_t i = 0; i < specs_.size(); ++i) setters_[i](o, j.at(specs_[i].name));
    return o;
  }
  nlohmann::json ToJson(const Options& o) const {
    nlohmann::json j = nlohmann::json::object();
    for (size_t i = 0; i < specs_.size(); ++i) j[specs_[i].name] = getters_[i](o);
    return j;
  }

 private:
  std::vector<std::function<nlohmann::json(const Options&)>> getters_;
  std::vector<std::function<void(Options&, const nlohmann::json&)>> setters_;
};

/// "disparity.p2 = 5 violates p2 > p1 (p1 = 8)": the one wording used for
/// cross-field rules in every Check().
std::string RuleViolation(const std::string& stage, const std::string& name, const nlohmann::json& value,
                          const std::string& rule, const std::string& context = "");

/// Throws OptionError with RuleViolation(...) unless `ok`.
inline void CheckRule(bool ok, const std::string& stage, const std::string& name, const nlohmann::json& value,
                      const std::string& rule, const std::string& context = "") {
  if (!ok) throw OptionError(RuleViolation(stage, name, value, rule, context));
}

}  // namespace rs
