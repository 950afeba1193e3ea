// The stages this program runs, in pipeline order.
#include "cli/command.h"
#include "stages/damage/damage_stage.h"
#include "stages/damage_map/damage_map_stage.h"
#include "stages/disparity/disparity_stage.h"
#include "stages/georeference/georeference_stage.h"
#include "stages/ingest/ingest_stage.h"
#include "stages/refine/refine_stage.h"
#include "stages/report/report_stage.h"
#include "stages/slam/slam_stage.h"
#include "stages/surface/surface_stage.h"
#include "survey/stage.h"

namespace rs {

void RegisterBuiltinStages(StageRegistry& registry) {
  registry.Add(std::make_unique<IngestStage>());
  registry.Add(std::make_unique<DisparityStage>());
  registry.Add(std::make_unique<DamageStage>());
  registry.Add(std::make_unique<SlamStage>());
  registry.Add(std::make_unique<RefineStage>());
  registry.Add(std::make_unique<GeoreferenceStage>());
  registry.Add(std::make_unique<DamageMapStage>());
  registry.Add(std::make_unique<SurfaceStage>());
  registry.Add(std::make_unique<ReportStage>());
}

}  // namespace rs
