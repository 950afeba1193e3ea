#pragma once
// Survey-level figures of a simulator evaluation: each truth pothole once, measured from the
// observation the stage itself would keep. A survey reports a pothole once, not once per frame,
// and the frame to keep is decided from the stage's own outputs (floor seen first, then the
// smallest stated depth uncertainty σ_Z), never from the truth. Per-observation figures
// (SimDamageEvaluation) stay the primary ones; these show what a survey-level merge delivers.

#include "eval/damage/sim_damage_eval.h"

#include <string>
#include <vector>

namespace rs {

/// Each scored truth pothole once.
struct SimDamageSurveyFigures {
  int potholes = 0;  ///< distinct truth potholes with at least one scored observation
  int detected = 0;  ///< of those: matched in at least one frame
  double recall = 0;
  /// The kept observation's errors (measured − truth): max depth where the stage says the floor
  /// is seen (mm), area and volume against the true values (%), over the detected potholes.
  DamageErrorStats seen_depth_error_mm, area_error_pct, volume_error_pct;
  int floor_seen = 0;  ///< kept observations whose floor the stage says it sees
  double severity_agreement = 0;
  DamageErrorStats kept_range_m;         ///< range of the kept observations (n, mean, median |.|, max)
  std::vector<PotholeObservation> kept;  ///< the kept observation per detected pothole
  std::string Report() const;
};

/// The observation of one pothole a survey keeps: among the matched ones, a seen floor first,
/// then the smallest σ_Z; ties by frame name. Returns nullptr when none matched.
const PotholeObservation* KeptObservation(const std::vector<const PotholeObservation*>& observations);

/// Per-pothole figures over `evaluation.observations`.
SimDamageSurveyFigures SummarisePerPothole(const SimDamageEvaluation& evaluation);

}  // namespace rs
