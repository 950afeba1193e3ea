#include "survey/job_graph.h"

#include <fmt/format.h>

#include <functional>
#include <stdexcept>

namespace rs {

bool IsSourceArtifact(const std::string& artifact) { return artifact == kSurveyInputs || artifact == kSurveyCrs; }

JobGraph JobGraph::Build(const StageRegistry& registry) {
  JobGraph g;
  for (const auto& stage : registry.stages()) {
    for (const auto& artifact : stage->info().outputs) {
      if (IsSourceArtifact(artifact) || g.producer_.count(artifact))
        throw std::logic_error(fmt::format("artifact '{}' has two producers ({} and {})", artifact,
                                           g.producer_.count(artifact) ? g.producer_[artifact] : "survey file",
                                           stage->info().name));
      g.producer_[artifact] = stage->info().name;
    }
  }
  for (const auto& stage : registry.stages()) {
    const std::string& name = stage->info().name;
    g.consumers_[name];
    for (const auto& artifact : stage->info().inputs) {
      if (IsSourceArtifact(artifact)) continue;
      const auto it = g.producer_.find(artifact);
      if (it == g.producer_.end())
        throw std::logic_error(fmt::format("stage '{}' consumes '{}', which no stage produces", name, artifact));
      g.producers_of_[name].insert(it->second);
      g.consumers_[it->second].insert(name);
    }
  }
  // Depth-first topological sort, stable in registration order.
  std::map<std::string, int> state;  // 0 new, 1 visiting, 2 done
  std::function<void(const Stage*)> visit = [&](const Stage* s) {
    const std::string& name = s->info().name;
    if (state[name] == 2) return;
    if (state[name] == 1) throw std::logic_error(fmt::format("stage graph has a cycle through '{}'", name));
    state[name] = 1;
    for (const auto& dep : g.producers_of_[name]) visit(registry.Find(dep));
    state[name] = 2;
    g.order_.push_back(s);
  };
  for (const auto& stage : registry.stages()) visit(stage.get());
  return g;
}

std::string JobGraph::ProducerOf(const std::string& artifact) const {
  const auto it = producer_.find(artifact);
  return it == producer_.end() ? std::string() : it->second;
}

std::set<std::string> JobGraph::Downstream(const std::string& stage) const {
  std::set<std::string> out{stage};
  std::vector<std::string> todo{stage};
  while (!todo.empty()) {
    const std::string s = todo.back();
    todo.pop_back();
    const auto it = consumers_.find(s);
    if (it == consumers_.end()) continue;
    for (const auto& c : it->second)
      if (out.insert(c).second) todo.push_back(c);
  }
  return out;
}

std::set<std::string> JobGraph::Upstream(const std::string& stage) const {
  std::set<std::string> out;
  std::vector<std::string> todo{stage};
  while (!todo.empty()) {
    const std::string s = todo.back();
    todo.pop_back();
    const auto it = producers_of_.find(s);
    if (it == producers_of_.end()) continue;
    for (const auto& p : it->second)
      if (out.insert(p).second) todo.push_back(p);
  }
  return out;
}

std::string JobGraph::Dot() const {
  std::string dot = "digraph roadsurvey {\n  rankdir=LR;\n  node [shape=box];\n";
  for (const Stage* s : order_) {
    for (const auto& artifact : s->info().inputs) {
      const std::string from = IsSourceArtifact(artifact) ? artifact : ProducerOf(artifact);
      dot += fmt::format("  \"{}\" -> \"{}\" [label=\"{}\"];\n", from, s->info().name, artifact);
    }
  }
  return dot + "}\n";
}

}  // namespace rs
