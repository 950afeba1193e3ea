#pragma once
// Stage "damage": per frame, the 3-D road surface model (obstacles removed),
// transformed disparity and depth below the road, damage segmentation,
// per-damage measurements and severity. Docs: docs/stages/damage.md.

#include "stages/damage/damage_pipeline.h"
#include "survey/stage.h"

namespace rs {

/// The algorithm's options (each sub-struct registered once) plus what to write.
struct DamageStageOptions {
  DamageOptions damage;
  bool write_overlay = true;    ///< overlay PNG (damage outlined and labelled on the left image)
  bool write_relief = true;     ///< transformed disparity and depth below the road (float TIFFs)
  bool skip_bad_frames = true;  ///< skip and count frames whose inputs cannot be read

  void Check() const;
  static const OptionTable<DamageStageOptions>& Table();
};

class DamageStage : public TypedStage<DamageStage, DamageStageOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const DamageStageOptions& options) const;
  /// The learned crack model's SHA-256 when the stage runs it (a new model redoes the stage).
  std::string ExtraKeyOf(const SurveyFile& survey, const DamageStageOptions& options) const;
};

}  // namespace rs
