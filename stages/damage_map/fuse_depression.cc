#include "stages/damage_map/fuse_depression.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace rs {
namespace {

// 0: whole outline and floor seen; 1: whole outline; 2: cut by the image border.
int Rank(const MapObservation& o) { return !o.complete ? 2 : o.detection.floor_visible ? 0 : 1; }

double SigmaOrInf(double s) { return std::isfinite(s) && s > 0 ? s : INFINITY; }

// Inverse-variance weighted mean of (value, σ) pairs with finite values; σ as documented in the header.
FusedValue Fuse(const std::vector<std::pair<double, double>>& views) {
  double sw = 0, swx = 0, sws = 0;
  std::vector<std::pair<double, double>> finite;
  for (const auto& [x, s] : views)
    if (std::isfinite(x)) finite.emplace_back(x, s);
  if (finite.empty()) return {};
  for (const auto& [x, s] : finite) {
    const double sigma = SigmaOrInf(s);
    const double w = std::isfinite(sigma) ? 1 / (sigma * sigma) : 1e-30;
    sw += w;
    swx += w * x;
    sws += w * (std::isfinite(sigma) ? sigma : 0);
  }
  FusedValue f;
  f.value = swx / sw;
  double scatter = 0;
  if (finite.size() > 1) {
    for (const auto& [x, s] : finite) scatter += (x - f.value) * (x - f.value);
    scatter = std::sqrt(scatter / static_cast<double>(finite.size() - 1));
  }
  const double mean_sigma = sws / sw;
  f.sigma = std::max(mean_sigma > 0 ? mean_sigma : scatter, scatter);
  if (!(f.sigma > 0)) f.sigma = kNotMeasured;
  return f;
}

std::string FrameList(const std::vector<MapObservation>& obs, const std::vector<int>& used) {
  std::string s;
  for (size_t i = 0; i < used.size(); ++i) s += (i ? ", " : "") + std::to_string(obs[used[i]].frame);
  return s;
}

}  // namespace

MappedDamage FuseDepression(const std::vector<MapObservation>& obs, const std::vector<int>& members,
                            const FusionOptions& o) {
  MappedDamage m;
  m.members = members;
  std::vector<int> order = members;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const int ra = Rank(obs[a]), rb = Rank(obs[b]);
    if (ra != rb) return ra < rb;
    return SigmaOrInf(obs[a].detection.sigma_depth_m) < SigmaOrInf(obs[b].detection.sigma_depth_m);
  });
  const int best_rank = Rank(obs[order.front()]);
  for (int i : order)
    if (Rank(obs[i]) == best_rank && static_cast<int>(m.used.size()) < o.best_views) m.used.push_back(i);
  m.best = m.used.front();
  m.outline_complete = best_rank < 2;
  m.floor_visible = best_rank == 0;
  static const char* kWhy[] = {"whole outline and floor in view", "whole outline in view, floor hidden by the near rim",
                               "no view holds the whole outline (area and volume are lower bounds)"};
  m.basis = fmt::format("{} of {} view(s) fused ({}): frames {}", m.used.size(), members.size(), kWhy[best_rank],
                        FrameList(obs, m.used));

  // Type: the used views' majority (pothole beats other on a tie: the stricter test passed).
  std::map<std::string, int> votes;
  for (int i : m.used) ++votes[obs[i].detection.type];
  m.type = votes["pothole"] >= votes["other"] ? "pothole" : "other";

  std::vector<std::pair<double, double>> depth, mean_depth, area, volume;
  std::vector<double> diameters;
  for (int i : m.used) {
    const DamageDetection& d = obs[i].detection;
    depth.emplace_back(d.max_depth_m, d.sigma_depth_m);
    mean_depth.emplace_back(d.mean_depth_m, d.sigma_depth_m);
    area.emplace_back(d.area_m2, d.sigma_area_m2);
    volume.emplace_back(d.volume_m3, d.sigma_volume_m3);
    if (std::isfinite(d.max_diameter_m)) diameters.push_back(d.max_diameter_m);
  }
  m.max_depth_m = Fuse(depth);
  m.mean_depth_m = Fuse(mean_depth);
  m.area_m2 = Fuse(area);
  m.volume_m3 = Fuse(volume);
  if (!diameters.empty()) {
    std::nth_element(diameters.begin(), diameters.begin() + diameters.size() / 2, diameters.end());
    m.max_diameter_m = diameters[diameters.size() / 2];
  }
  if (std::isfinite(m.area_m2.value)) m.equivalent_diameter_m = std::sqrt(4 * m.area_m2.value / M_PI);

  if (!m.floor_visible) {
    // Every view's seen depth (less 2σ) is a lower bound of the true depth and every view's
    // geometric bound an upper one: the interval is their intersection.
    double lo = -INFINITY, hi = INFINITY, vhi = INFINITY;
    for (int i : members) {
      const DamageDetection& d = obs[i].detection;
      if (std::isfinite(d.max_depth_seen_m))
        lo = std::max(lo, d.max_depth_seen_m - 2 * (std::isfinite(d.sigma_depth_m) ? d.sigma_depth_m : 0));
      if (obs[i].complete && std::isfinite(d.max_depth_bound_m)) hi = std::min(hi, d.max_depth_bound_m);
      if (obs[i].complete && std::isfinite(d.volume_upper_m3)) vhi = std::min(vhi, d.volume_upper_m3);
    }
    m.max_depth_seen_m = std::isfinite(lo) ? std::max(0.0, lo) : kNotMeasured;
    m.max_depth_bound_m = std::isfinite(hi) ? hi : kNotMeasured;
    if (std::isfinite(m.max_depth_seen_m) && std::isfinite(m.max_depth_bound_m) &&
        m.max_depth_bound_m < m.max_depth_seen_m)
      m.max_depth_bound_m = m.max_depth_seen_m;  // views disagree beyond their σ: keep a valid interval
    if (std::isfinite(m.max_depth_m.value) && std::isfinite(m.max_depth_seen_m) && std::isfinite(m.max_depth_bound_m))
      m.max_depth_m.value = std::clamp(m.max_depth_m.value, m.max_depth_seen_m, m.max_depth_bound_m);
    m.volume_upper_m3 = std::isfinite(vhi) ? vhi : kNotMeasured;
  }

  const MapObservation& best = obs[m.best];
  m.geometry_enu = best.outline_enu;
  // The centroid from every used view (pose noise averages), the outline from the best one.
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i : m.used) {
    const Eigen::Vector2d xy = RingCentroid(obs[i].outline_enu);
    double z = 0;
    for (const auto& p : obs[i].outline_enu) z += p.z();
    c += Eigen::Vector3d(xy.x(), xy.y(), z / static_cast<double>(obs[i].outline_enu.size()));
  }
  m.centroid_enu = c / static_cast<double>(m.used.size());
  return m;
}

void GradeMappedDamage(MappedDamage& m, const SeverityOptions& o) {
  m.astm = {};
  m.fhwa = {};
  if (m.type == "crack") {
    m.fhwa = GradeFhwaCrack(m.width_m.value, o);
    m.intervention = GradeCrackIntervention(m.max_width_m, o);
    m.severity = SeverityLevelName(m.fhwa.level);
    return;
  }
  if (m.type == "pothole") {
    m.astm = GradeAstmPothole(m.max_depth_m.value, m.equivalent_diameter_m, m.area_m2.value, o);
    m.fhwa = GradeFhwaPothole(m.max_depth_m.value, m.equivalent_diameter_m, o);
    m.severity = SeverityLevelName(m.astm.level);
  } else {
    m.astm.rule = "ASTM D6433: not a pothole (type other)";
    m.fhwa.rule = "FHWA LTPP: not a pothole (type other)";
    m.severity = "none";
  }
  m.intervention = GradeDepressionIntervention(m.max_depth_m.value, m.max_diameter_m, o);
}

}  // namespace rs
