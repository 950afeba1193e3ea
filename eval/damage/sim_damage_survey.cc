#include "eval/damage/sim_damage_survey.h"

#include <cctype>
#include <cmath>
#include <map>

#include <fmt/format.h>

namespace rs {

const PotholeObservation* KeptObservation(const std::vector<const PotholeObservation*>& observations) {
  const PotholeObservation* best = nullptr;
  auto better = [](const PotholeObservation& a, const PotholeObservation& b) {
    if (a.floor_visible != b.floor_visible) return a.floor_visible;
    if (a.sigma_depth_m != b.sigma_depth_m) return a.sigma_depth_m < b.sigma_depth_m;
    return a.frame < b.frame;
  };
  for (const PotholeObservation* o : observations)
    if (o->detected && (!best || better(*o, *best))) best = o;
  return best;
}

SimDamageSurveyFigures SummarisePerPothole(const SimDamageEvaluation& evaluation) {
  std::map<int, std::vector<const PotholeObservation*>> by_pothole;
  for (const PotholeObservation& o : evaluation.observations) by_pothole[o.truth_id].push_back(&o);
  SimDamageSurveyFigures f;
  f.potholes = static_cast<int>(by_pothole.size());
  std::vector<double> depth_mm, area_pct, volume_pct, range_m;
  int severity_ok = 0;
  for (const auto& [id, observations] : by_pothole) {
    const PotholeObservation* k = KeptObservation(observations);
    if (!k) continue;
    ++f.detected;
    f.kept.push_back(*k);
    if (k->floor_visible) {
      ++f.floor_seen;
      depth_mm.push_back(k->MaxDepthErrorMm());
    }
    area_pct.push_back(k->AreaErrorPct());
    volume_pct.push_back(k->VolumeErrorPct());
    range_m.push_back(k->range_m);
    const char letter = static_cast<char>(std::toupper(SeverityLevelName(k->astm)[0]));
    severity_ok += k->truth_severity == std::string(1, letter);
  }
  f.recall = f.potholes ? double(f.detected) / f.potholes : 0.0;
  f.seen_depth_error_mm = ComputeDamageErrorStats(depth_mm);
  f.area_error_pct = ComputeDamageErrorStats(area_pct);
  f.volume_error_pct = ComputeDamageErrorStats(volume_pct);
  f.kept_range_m = ComputeDamageErrorStats(range_m);
  f.severity_agreement = f.detected ? double(severity_ok) / f.detected : 0.0;
  return f;
}

std::string SimDamageSurveyFigures::Report() const {
  auto stats = [](const DamageErrorStats& s, const char* unit) {
    return fmt::format("bias {:.1f}{u}, median |e| {:.1f}{u}, max {:.1f}{u} (n {})", s.mean, s.median_abs, s.max_abs,
                       s.n, fmt::arg("u", unit));
  };
  return fmt::format(
      "per pothole (each truth pothole once, from the observation the stage keeps: floor seen, then least sigma_Z):\n"
      "  recall {:.3f} ({}/{}); kept range mean {:.1f} m, max {:.1f} m; floor seen in {}\n"
      "  max depth error (floor seen): {}\n  area error: {}\n  volume error: {}\n"
      "  severity agreement {:.1f} %\n",
      recall, detected, potholes, kept_range_m.mean, kept_range_m.max_abs, floor_seen,
      stats(seen_depth_error_mm, " mm"), stats(area_error_pct, " %"), stats(volume_error_pct, " %"),
      100 * severity_agreement);
}

}  // namespace rs
