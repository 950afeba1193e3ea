#pragma once
// Stage "refine": bundle adjustment of the SLAM map by COLMAP's rig bundle adjuster (left and
// right camera as a rig of fixed, known relative pose), then the result put back into the SLAM
// world frame and every frame carried along with its keyframes. Docs: docs/stages/refine.md.

#include <string>

#include "stages/refine/colmap_export.h"
#include "stages/refine/gauge.h"
#include "survey/stage.h"

namespace rs {

struct RefineOptions {
  bool enabled = true;                   ///< false: pass the SLAM trajectory and map through unchanged
  std::string colmap_program = "colmap"; ///< the COLMAP executable (a name looked up in PATH, or a path)
  ObservationSelection selection;        ///< which observations the bundle adjustment sees
  int max_iterations = 100;              ///< COLMAP's BundleAdjustment.max_num_iterations
  double function_tolerance = 1e-6;      ///< COLMAP's BundleAdjustment.function_tolerance (Ceres' default)
  GaugeAnchor anchor = GaugeAnchor::kKeyframes;

  void Check() const;
  static const OptionTable<RefineOptions>& Table();
};

class RefineStage : public TypedStage<RefineStage, RefineOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const RefineOptions& options) const;
  void ValidateInputs(const SurveyFile& survey, const RefineOptions& options, ValidationDepth depth,
                      ProblemList& problems) const;
};

}  // namespace rs
