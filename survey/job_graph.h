#pragma once
// The DAG of stages over artifacts: a stage depends on the stages producing
// the artifacts it consumes. Built from the registry's declarations.

#include <map>
#include <set>
#include <string>
#include <vector>

#include "survey/stage.h"

namespace rs {

/// Artifacts that come from the survey file rather than from a stage.
inline constexpr const char* kSurveyCrs = "survey.crs";
bool IsSourceArtifact(const std::string& artifact);

class JobGraph {
 public:
  /// Throws std::logic_error on an artifact with no or two producers, or a cycle.
  static JobGraph Build(const StageRegistry& registry);

  /// Stages in an order where every stage follows its producers.
  const std::vector<const Stage*>& order() const { return order_; }
  /// Name of the stage producing `artifact`, or "" for source artifacts.
  std::string ProducerOf(const std::string& artifact) const;
  /// `stage` and every stage that (transitively) consumes its outputs.
  std::set<std::string> Downstream(const std::string& stage) const;
  /// Every stage `stage` (transitively) needs, excluding itself.
  std::set<std::string> Upstream(const std::string& stage) const;
  /// Graphviz rendering (docs/architecture.md's picture is made from it).
  std::string Dot() const;

 private:
  std::vector<const Stage*> order_;
  std::map<std::string, std::string> producer_;                // artifact -> stage
  std::map<std::string, std::set<std::string>> consumers_;     // stage -> direct dependents
  std::map<std::string, std::set<std::string>> producers_of_;  // stage -> direct dependencies
};

}  // namespace rs
