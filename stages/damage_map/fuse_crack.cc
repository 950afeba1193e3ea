#include "stages/damage_map/fuse_crack.h"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include <algorithm>
#include <cmath>
#include <queue>

namespace rs {
namespace {

constexpr int kMaxGridCells = 4000;

// Farthest skeleton pixel from `start` (8-connected BFS) and the parent links to walk back.
cv::Point Farthest(const cv::Mat& skel, cv::Point start, cv::Mat* parent) {
  cv::Mat dist(skel.size(), CV_32SC1, cv::Scalar(-1));
  *parent = cv::Mat(skel.size(), CV_32SC1, cv::Scalar(-1));
  std::queue<cv::Point> q;
  q.push(start);
  dist.at<int>(start) = 0;
  cv::Point last = start;
  while (!q.empty()) {
    const cv::Point p = q.front();
    q.pop();
    last = p;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const cv::Point n(p.x + dx, p.y + dy);
        if ((dx == 0 && dy == 0) || n.x < 0 || n.y < 0 || n.x >= skel.cols || n.y >= skel.rows) continue;
        if (!skel.at<uchar>(n) || dist.at<int>(n) >= 0) continue;
        dist.at<int>(n) = dist.at<int>(p) + 1;
        parent->at<int>(n) = p.y * skel.cols + p.x;
        q.push(n);
      }
  }
  return last;
}

// Longest path of the largest skeleton component: two BFS sweeps (exact on a tree).
std::vector<cv::Point> LongestPath(const cv::Mat& skel) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(skel, labels, stats, centroids, 8);
  int biggest = 0;
  for (int i = 1; i < n; ++i)
    if (biggest == 0 || stats.at<int>(i, cv::CC_STAT_AREA) > stats.at<int>(biggest, cv::CC_STAT_AREA)) biggest = i;
  if (biggest == 0) return {};
  const cv::Mat component = labels == biggest;
  cv::Point seed;
  cv::minMaxLoc(component, nullptr, nullptr, nullptr, &seed);
  cv::Mat parent;
  const cv::Point a = Farthest(component, seed, &parent);
  const cv::Point b = Farthest(component, a, &parent);
  std::vector<cv::Point> path;
  for (int at = b.y * component.cols + b.x; at >= 0; at = parent.at<int>(at / component.cols, at % component.cols))
    path.emplace_back(at % component.cols, at / component.cols);
  return path;
}

}  // namespace

double PolylineLength(const std::vector<Eigen::Vector3d>& line) {
  double len = 0;
  for (size_t i = 1; i < line.size(); ++i) len += (line[i] - line[i - 1]).norm();
  return len;
}

std::vector<Eigen::Vector3d> MergedCenterline(const std::vector<const std::vector<Eigen::Vector3d>*>& rings,
                                              const CrackFusionOptions& o) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(INFINITY), hi = -lo;
  for (const auto* r : rings)
    for (const auto& p : *r) {
      lo = lo.cwiseMin(p.head<2>());
      hi = hi.cwiseMax(p.head<2>());
    }
  if (!lo.allFinite()) return {};
  lo.array() -= o.gap_m + 0.02;
  hi.array() += o.gap_m + 0.02;
  const double cell = std::max(o.cell_m, (hi - lo).maxCoeff() / kMaxGridCells);
  const cv::Size size(static_cast<int>(std::ceil((hi.x() - lo.x()) / cell)) + 1,
                      static_cast<int>(std::ceil((hi.y() - lo.y()) / cell)) + 1);
  cv::Mat mask = cv::Mat::zeros(size, CV_8UC1);
  for (const auto* r : rings) {
    std::vector<cv::Point> pts;
    for (const auto& p : *r)
      pts.emplace_back(static_cast<int>(std::lround((p.x() - lo.x()) / cell)),
                       static_cast<int>(std::lround((p.y() - lo.y()) / cell)));
    cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255));
    cv::polylines(mask, std::vector<std::vector<cv::Point>>{pts}, true, cv::Scalar(255));
  }
  const int gap = static_cast<int>(std::ceil(0.5 * o.gap_m / cell));
  if (gap > 0)
    cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * gap + 1, 2 * gap + 1)));
  cv::Mat skel;
  cv::ximgproc::thinning(mask, skel, cv::ximgproc::THINNING_ZHANGSUEN);
  std::vector<cv::Point> path = LongestPath(skel);
  if (path.size() < 2) return {};
  std::vector<cv::Point> simple;
  cv::approxPolyDP(path, simple, std::max(1.0, o.simplify_m / cell), false);
  std::vector<Eigen::Vector3d> line;
  for (const cv::Point& p : simple) {
    const Eigen::Vector2d xy(lo.x() + p.x * cell, lo.y() + p.y * cell);
    double best = INFINITY, z = 0;
    for (const auto* r : rings)
      for (const auto& q : *r)
        if (const double d = (q.head<2>() - xy).squaredNorm(); d < best) {
          best = d;
          z = q.z();
        }
    line.emplace_back(xy.x(), xy.y(), z);
  }
  return line;
}

MappedDamage FuseCrack(const std::vector<MapObservation>& obs, const std::vector<int>& members,
                       const CrackFusionOptions& o, const std::vector<std::vector<Eigen::Vector3d>>& bridges) {
  MappedDamage m;
  m.type = "crack";
  m.members = members;
  std::vector<const std::vector<Eigen::Vector3d>*> rings;
  for (int i : members) rings.push_back(&obs[i].outline_enu);
  for (const auto& b : bridges) rings.push_back(&b);
  m.geometry_enu = MergedCenterline(rings, o);
  if (m.geometry_enu.size() < 2) {  // a speck: the longest outline diameter stands in
    m.geometry_enu = {obs[members.front()].outline_enu.front(), obs[members.front()].outline_enu.back()};
  }
  m.length_m.value = PolylineLength(m.geometry_enu);
  m.length_m.sigma = o.gap_m;  // the merged outline's ends are known to the closing tolerance
  // Width: complete views nearest first (their pixels are smallest on the road).
  std::vector<int> order = members;
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    if (obs[a].complete != obs[b].complete) return obs[a].complete;
    return obs[a].detection.range_m < obs[b].detection.range_m;
  });
  m.best = order.front();
  std::vector<double> widths;
  for (int i : order) {
    if (std::isfinite(obs[i].detection.mean_width_m)) widths.push_back(obs[i].detection.mean_width_m);
    if (std::isfinite(obs[i].detection.max_width_m))
      m.max_width_m = std::isfinite(m.max_width_m) ? std::max(m.max_width_m, obs[i].detection.max_width_m)
                                                   : obs[i].detection.max_width_m;
    if (widths.size() >= 3) break;
  }
  m.used.assign(order.begin(), order.begin() + std::min<size_t>(order.size(), std::max<size_t>(1, widths.size())));
  if (!widths.empty()) {
    std::sort(widths.begin(), widths.end());
    m.width_m.value = widths[widths.size() / 2];
    m.width_m.sigma = widths.size() > 1 ? 0.5 * (widths.back() - widths.front()) : kNotMeasured;
  }
  m.outline_complete = obs[m.best].complete;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : m.geometry_enu) c += p;
  m.centroid_enu = c / static_cast<double>(m.geometry_enu.size());
  m.basis = fmt::format("{} view(s) merged into one centreline ({:.2f} m){}; width from the nearest whole view(s)",
                        members.size(), m.length_m.value,
                        bridges.empty() ? "" : fmt::format(", {} gap(s) between pieces bridged", bridges.size()));
  return m;
}

}  // namespace rs
