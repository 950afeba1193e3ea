#include "stages/damage_map/chainage.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rs {

Centreline::Centreline(const std::vector<Eigen::Vector3d>& track, double min_step_m, double same_road_m)
    : same_road_m_(same_road_m) {
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
  struct Candidate {
    double dist;
    Station station;
    bool interior;  // the foot lies inside its segment (or on an extrapolated end)
    Eigen::Vector2d direction;
  };
  std::vector<Candidate> candidates;
  const size_t last = points_.size() - 2;
  for (size_t i = 0; i + 1 < points_.size(); ++i) {
    const Eigen::Vector2d a = points_[i], d = points_[i + 1] - a;
    const double len = d.norm();
    const Eigen::Vector2d u = d / len;
    const double raw = (p - a).dot(u);
    double along = raw;
    // Clamp to the segment, except before the first and after the last (extrapolated stations).
    if (i > 0) along = std::max(along, 0.0);
    if (i < last) along = std::min(along, len);
    const double cross = u.x() * (p - a).y() - u.y() * (p - a).x();  // > 0: left of travel
    candidates.push_back({(p - (a + along * u)).norm(), {cumulative_[i] + along, -cross}, along == raw, u});
  }
  // The nearest pass; a road flown again (out and back) is referenced on its first pass: the
  // earliest foot inside a segment along the same line (within 30 deg, either way: not a turn)
  // within same_road_m of the nearest.
  const auto nearest = std::min_element(candidates.begin(), candidates.end(),
                                        [](const Candidate& x, const Candidate& y) { return x.dist < y.dist; });
  const double cos_same_line = std::cos(30.0 * M_PI / 180.0);
  Station s = nearest->station;
  for (const Candidate& c : candidates)
    if (c.interior && c.dist <= nearest->dist + same_road_m_ && c.station.chainage_m < s.chainage_m &&
        std::abs(c.direction.dot(nearest->direction)) >= cos_same_line)
      s = c.station;
  return s;
}

}  // namespace rs
