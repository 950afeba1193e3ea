#include "stages/damage_map/chainage.h"

#include <cmath>
#include <limits>

namespace rs {

Centreline::Centreline(const std::vector<Eigen::Vector3d>& track, double min_step_m) {
  for (const auto& p : track) {
    const Eigen::Vector2d xy = p.head<2>();
    if (!points_.empty() && (xy - points_.back()).norm() < min_step_m) continue;
    cumulative_.push_back(points_.empty() ? 0.0 : cumulative_.back() + (xy - points_.back()).norm());
    points_.push_back(xy);
  }
}

Centreline::Station Centreline::StationOf(const Eigen::Vector3d& p3) const {
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  if (!valid()) return {kNan, kNan};
  const Eigen::Vector2d p = p3.head<2>();
  double best = INFINITY;
  Station s{kNan, kNan};
  const size_t last = points_.size() - 2;
  for (size_t i = 0; i + 1 < points_.size(); ++i) {
    const Eigen::Vector2d a = points_[i], d = points_[i + 1] - a;
    const double len = d.norm();
    const Eigen::Vector2d u = d / len;
    double along = (p - a).dot(u);
    // Clamp to the segment, except before the first and after the last (extrapolated stations).
    if (i > 0) along = std::max(along, 0.0);
    if (i < last) along = std::min(along, len);
    const Eigen::Vector2d foot = a + along * u;
    const double dist = (p - foot).norm();
    if (dist < best) {
      best = dist;
      const double cross = u.x() * (p - a).y() - u.y() * (p - a).x();  // > 0: left of travel
      s = {cumulative_[i] + along, -cross};
    }
  }
  return s;
}

}  // namespace rs
