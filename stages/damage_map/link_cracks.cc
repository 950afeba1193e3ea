#include "stages/damage_map/link_cracks.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace rs {
namespace {

// The point `arc_m` along `line` from its first point (the last point where the line is shorter).
Eigen::Vector2d PointAlong(const std::vector<Eigen::Vector3d>& line, double arc_m) {
  double walked = 0;
  for (size_t i = 1; i < line.size(); ++i) {
    const Eigen::Vector2d a = line[i - 1].head<2>(), b = line[i].head<2>();
    const double step = (b - a).norm();
    if (walked + step >= arc_m && step > 0) return a + (b - a) * ((arc_m - walked) / step);
    walked += step;
  }
  return line.back().head<2>();
}

int Find(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

std::vector<CrackEnd> CrackEnds(const std::vector<Eigen::Vector3d>& line, double tangent_m) {
  if (line.size() < 2) return {};
  double length = 0;
  for (size_t i = 1; i < line.size(); ++i) length += (line[i] - line[i - 1]).head<2>().norm();
  const double arc = std::min(tangent_m, length);
  const std::vector<Eigen::Vector3d> reversed(line.rbegin(), line.rend());
  std::vector<CrackEnd> ends;
  for (const std::vector<Eigen::Vector3d>* l : {&line, &reversed}) {
    const Eigen::Vector2d end = l->front().head<2>();
    const Eigen::Vector2d out = end - PointAlong(*l, arc);
    ends.push_back({end, out.norm() > 0 ? Eigen::Vector2d(out.normalized()) : Eigen::Vector2d::Zero()});
  }
  return ends;
}

bool EndsFace(const CrackEnd& a, const CrackEnd& b, const CrackLinkOptions& o, double touch_m) {
  const Eigen::Vector2d gap = b.point - a.point;
  const double d = gap.norm();
  if (d <= touch_m) return true;
  if (d > o.max_gap_m) return false;
  const double cos_max = std::cos(o.max_angle_deg * M_PI / 180.0);
  const Eigen::Vector2d u = gap / d;
  return u.dot(a.outward) >= cos_max && (-u).dot(b.outward) >= cos_max;
}

std::vector<std::vector<int>> LinkCrackPieces(const std::vector<std::vector<Eigen::Vector3d>>& lines,
                                              const CrackLinkOptions& o, double touch_m,
                                              std::vector<CrackBridge>* bridges) {
  const int n = static_cast<int>(lines.size());
  std::vector<std::vector<CrackEnd>> ends(n);
  for (int i = 0; i < n; ++i) ends[i] = CrackEnds(lines[i], o.tangent_m);
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  if (bridges) bridges->clear();
  if (o.max_gap_m > 0)
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        for (int ei = 0; ei < static_cast<int>(ends[i].size()); ++ei)
          for (int ej = 0; ej < static_cast<int>(ends[j].size()); ++ej) {
            if (!EndsFace(ends[i][ei], ends[j][ej], o, touch_m)) continue;
            parent[Find(parent, i)] = Find(parent, j);
            if (bridges) {
              const Eigen::Vector3d& pa = ei == 0 ? lines[i].front() : lines[i].back();
              const Eigen::Vector3d& pb = ej == 0 ? lines[j].front() : lines[j].back();
              bridges->push_back({i, {pa, pb}});
            }
          }
  std::vector<std::vector<int>> groups;
  std::vector<int> group_of(n, -1);
  for (int i = 0; i < n; ++i) {
    const int root = Find(parent, i);
    if (group_of[root] < 0) {
      group_of[root] = static_cast<int>(groups.size());
      groups.emplace_back();
    }
    groups[group_of[root]].push_back(i);
  }
  return groups;
}

}  // namespace rs
