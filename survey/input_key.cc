#include "survey/input_key.h"

#include <memory>
#include <set>

#include "survey/job_graph.h"

namespace rs {

OutputExclusion SurveyOutputExclusion(const StageRegistry& registry, const SurveyFile& survey) {
  auto published = std::make_shared<std::set<std::string>>();
  for (const auto& stage : registry.stages())
    for (const auto& pub : stage->info().published)
      published->insert(std::filesystem::path(pub.to).begin()->string());  // "disparity" of "disparity/..."
  OutputExclusion exclusion;
  exclusion.dir = survey.output_dir;
  exclusion.owned = [published](const std::string& name) {
    return name == "work" || name == "manifest.json" || name.rfind("frames-", 0) == 0 || name.rfind('.', 0) == 0 ||
           published->count(name) > 0;
  };
  return exclusion;
}

std::string SourceKey(const SurveyFile& survey, const std::string& artifact, const OutputExclusion& output) {
  KeyHasher h;
  h.Add(artifact);
  if (artifact == kSurveyCrs) {
    h.Add(survey.crs);
    return h.Hex();
  }
  h.Add(survey.inputs.dump());
  for (const auto& [name, spec] : survey.inputs.items()) {
    if (const auto p = survey.InputPath(name)) h.Add(name).Add(FingerprintPath(*p, output));
  }
  return h.Hex();
}

}  // namespace rs
