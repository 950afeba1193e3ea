#pragma once
// Obstacles leave the damage errors and the road model unchanged, as a paired comparison: the
// same simulated flight (seed, road, damage, trajectory) rendered with and without its parked
// cars and people, evaluated alike. Each pothole observation scored in both renders (same frame,
// same truth pothole) gives the difference its errors take from the obstacles; observations an
// obstacle hides or that are scored in one render only are counted, not compared.

#include "eval/damage/sim_damage_eval.h"

#include <string>

namespace rs {

/// Differences (with obstacles − without) over the observations matched in both evaluations.
struct PairedObstacleFigures {
  int paired = 0;               ///< observations scored in both renders and detected in both
  int only_with = 0;            ///< scored in both, detected only with the obstacles
  int only_without = 0;         ///< scored in both, detected only without them
  int scored_only_without = 0;  ///< scored only without the obstacles (hidden by one, or its ground)
  /// Per paired observation: Δ|area error| and Δ|volume error| (percentage points), Δ|max depth
  /// error| (mm, where both say the floor is seen). Positive: worse with the obstacles.
  DamageErrorStats area_pp, volume_pp, depth_mm;
  double worst_area_pp = 0, worst_volume_pp = 0, worst_depth_mm = 0;  ///< largest worsening (≥ 0)
  double road_delta_mm = 0;  ///< road model median |error| with minus without, mm
  std::string Report() const;
};

/// Pairs `with_obstacles` and `without` by (frame, truth pothole id).
PairedObstacleFigures CompareObstacleRenders(const SimDamageEvaluation& with_obstacles,
                                             const SimDamageEvaluation& without);

}  // namespace rs
