#pragma once
// Stage "slam": stereo visual SLAM over the survey's frames in time order,
// with the flight log's GNSS as position priors. Publishes trajectory.tum.
// Docs: docs/stages/slam.md.

#include "stages/slam/slam_options.h"
#include "survey/stage.h"

namespace rs {

/// The SLAM's options (registered field by field) plus how priors are used.
struct SlamStageOptions {
  SlamOptions slam;
  bool use_gnss_priors = true;         ///< pass each frame's GNSS position (local ENU) as a prior
  double default_prior_sigma_m = 3.0;  ///< position sigma when the log gives no accuracy, m

  void Check() const;
  static const OptionTable<SlamStageOptions>& Table();
};

class SlamStage : public TypedStage<SlamStage, SlamStageOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const SlamStageOptions& options) const;
};

}  // namespace rs
