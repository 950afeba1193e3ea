#pragma once
// Fusion of a depression's (pothole or other) views: the best views decide, not the average of
// all. Views rank by what they can see: the whole outline and the floor, then the whole outline,
// then the rest; within a rank by depth uncertainty (near range first).

#include <vector>

#include "stages/damage_map/mapped_damage.h"

namespace rs {

struct FusionOptions {
  int best_views = 3;  ///< views of the best rank the measurements are fused from
};

/// Fuses the views `members` (indices into `obs`) of one depression. Estimates are the
/// inverse-variance weighted means over the used views; their σ is the weighted mean of the
/// views' σ (views of one surface share its errors, so σ does not shrink as 1/√n), raised to the
/// views' scatter where that is larger. Severity is left to the caller.
MappedDamage FuseDepression(const std::vector<MapObservation>& obs, const std::vector<int>& members,
                            const FusionOptions& options);

/// Grades a fused depression or crack on its fused figures (ASTM, FHWA, intervention, severity).
void GradeMappedDamage(MappedDamage& damage, const SeverityOptions& options);

}  // namespace rs
