#pragma once
// Per-frame timing of the damage algorithm (`roadsurvey bench damage`) on a synthetic frame
// with known content, so the figure is comparable between machines and builds.

#include <vector>

#include "stages/damage/damage_pipeline.h"

namespace rs {

/// Per-frame timing of the damage stage beyond the disparity on BenchmarkRoadScene (several
/// potholes, a slab, cracks, noisy disparity with holes): DetectDamage with the left image,
/// the overlay and the detections JSON (as text), medians over runs. PNG encoding and file
/// writing are timed separately (`encode_ms`) and not included in wall_ms / cpu_ms.
struct DamageBench {
  double wall_ms = 0;             ///< elapsed time (inflated when other processes share the cores)
  double cpu_ms = 0;              ///< process CPU time summed over threads: the single-core wall time bound
  std::vector<PassTime> pass_ms;  ///< median wall time of each pass of DetectDamage (DamagePassNames order)
  double outputs_ms = 0;          ///< overlay and detections JSON (wall)
  double encode_ms = 0;           ///< PNG encoding of the label image and the overlay (wall), not in the above
  int potholes = 0, cracks = 0, others = 0;  ///< instances found in the frame (last run)
};
/// Runs the per-frame work `repeats` times on a width × height BenchmarkRoadScene.
DamageBench BenchDetectDamage(int width, int height, int repeats);

}  // namespace rs
