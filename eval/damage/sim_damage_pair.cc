#include "eval/damage/sim_damage_pair.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <fmt/format.h>

namespace rs {

PairedObstacleFigures CompareObstacleRenders(const SimDamageEvaluation& with_obstacles,
                                             const SimDamageEvaluation& without) {
  std::map<std::pair<std::string, int>, const PotholeObservation*> with;
  for (const PotholeObservation& o : with_obstacles.observations) with[{o.frame, o.truth_id}] = &o;
  PairedObstacleFigures f;
  std::vector<double> area, volume, depth;
  for (const PotholeObservation& b : without.observations) {
    const auto it = with.find({b.frame, b.truth_id});
    if (it == with.end()) {
      ++f.scored_only_without;
      continue;
    }
    const PotholeObservation& a = *it->second;
    if (a.detected != b.detected) {
      ++(a.detected ? f.only_with : f.only_without);
      continue;
    }
    if (!a.detected) continue;
    ++f.paired;
    area.push_back(std::abs(a.AreaErrorPct()) - std::abs(b.AreaErrorPct()));
    volume.push_back(std::abs(a.VolumeErrorPct()) - std::abs(b.VolumeErrorPct()));
    if (a.floor_visible && b.floor_visible)
      depth.push_back(std::abs(a.MaxDepthErrorMm()) - std::abs(b.MaxDepthErrorMm()));
  }
  auto worst = [](const std::vector<double>& v) {
    return v.empty() ? 0.0 : std::max(0.0, *std::max_element(v.begin(), v.end()));
  };
  f.worst_area_pp = worst(area), f.worst_volume_pp = worst(volume), f.worst_depth_mm = worst(depth);
  f.area_pp = ComputeDamageErrorStats(std::move(area));
  f.volume_pp = ComputeDamageErrorStats(std::move(volume));
  f.depth_mm = ComputeDamageErrorStats(std::move(depth));
  f.road_delta_mm = with_obstacles.road_median_abs_mm - without.road_median_abs_mm;
  return f;
}

std::string PairedObstacleFigures::Report() const {
  return fmt::format(
      "obstacles against the same flight without them: {} observations paired; detected only with obstacles {}, "
      "only without {}; scored only without {}\n"
      "  change of |error| (with - without): area mean {:+.2f} pp, worst {:.1f} pp; volume mean {:+.2f} pp, worst "
      "{:.1f} pp; max depth (floor seen, n {}) mean {:+.2f} mm, worst {:.1f} mm; road model {:+.2f} mm\n",
      paired, only_with, only_without, scored_only_without, area_pp.mean, worst_area_pp, volume_pp.mean,
      worst_volume_pp, depth_mm.n, depth_mm.mean, worst_depth_mm, road_delta_mm);
}

}  // namespace rs
