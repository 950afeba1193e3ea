// The stages this program runs, in pipeline order.
#include "cli/command.h"
#include "stages/ingest/ingest_stage.h"
#include "survey/stage.h"

namespace rs {

void RegisterBuiltinStages(StageRegistry& registry) {
  registry.Add(std::make_unique<IngestStage>());
}

}  // namespace rs
