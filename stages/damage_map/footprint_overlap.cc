#include "stages/damage_map/footprint_overlap.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

namespace rs {
namespace {

// The largest grid side: wider pairs (long cracks) are compared on a coarser grid.
constexpr int kMaxGridCells = 2000;

cv::Mat Rasterise(const Footprint& f, const Eigen::Vector2d& origin, double cell, cv::Size size) {
  cv::Mat mask = cv::Mat::zeros(size, CV_8UC1);
  std::vector<cv::Point> pts;
  for (const auto& p : f.ring)
    pts.emplace_back(static_cast<int>(std::lround((p.x() - origin.x()) / cell)),
                     static_cast<int>(std::lround((p.y() - origin.y()) / cell)));
  cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255));
  cv::polylines(mask, std::vector<std::vector<cv::Point>>{pts}, true, cv::Scalar(255));  // thin rings keep pixels
  return mask;
}

int Find(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

Footprint FootprintOf(const std::vector<Eigen::Vector3d>& ring) {
  Footprint f;
  f.lo = Eigen::Vector2d::Constant(INFINITY);
  f.hi = Eigen::Vector2d::Constant(-INFINITY);
  for (const auto& p : ring) {
    f.ring.push_back(p.head<2>());
    f.lo = f.lo.cwiseMin(p.head<2>());
    f.hi = f.hi.cwiseMax(p.head<2>());
  }
  return f;
}

double OverlapOfSmaller(const Footprint& a, const Footprint& b, double tol, double cell) {
  if (a.ring.size() < 3 || b.ring.size() < 3) return 0;
  if ((a.lo.array() > b.hi.array() + tol).any() || (b.lo.array() > a.hi.array() + tol).any()) return 0;
  const Eigen::Vector2d lo = a.lo.cwiseMin(b.lo).array() - tol - 2 * cell;
  const Eigen::Vector2d hi = a.hi.cwiseMax(b.hi).array() + tol + 2 * cell;
  cell = std::max(cell, (hi - lo).maxCoeff() / kMaxGridCells);
  const cv::Size size(static_cast<int>(std::ceil((hi.x() - lo.x()) / cell)) + 1,
                      static_cast<int>(std::ceil((hi.y() - lo.y()) / cell)) + 1);
  const cv::Mat ma = Rasterise(a, lo, cell, size), mb = Rasterise(b, lo, cell, size);
  const int r = static_cast<int>(std::ceil(tol / cell));
  cv::Mat da, db;  // fresh buffers: a header copy would share ma's pixels and dilate it too
  if (r > 0) {
    const cv::Mat disk = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1));
    cv::dilate(ma, da, disk);
    cv::dilate(mb, db, disk);
  } else {
    da = ma;
    db = mb;
  }
  const double na = cv::countNonZero(ma), nb = cv::countNonZero(mb);
  if (na == 0 || nb == 0) return 0;
  // The smaller footprint inside the other's buffer is the larger of the two fractions.
  const double b_in_a = cv::countNonZero(da & mb) / nb, a_in_b = cv::countNonZero(db & ma) / na;
  return std::max(a_in_b, b_in_a);
}

std::vector<std::vector<int>> GroupByOverlap(const std::vector<Footprint>& f, double tol, double cell,
                                             double min_overlap) {
  const int n = static_cast<int>(f.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  // Sweep along x: only pairs whose buffered boxes meet are rasterised.
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int i, int j) { return f[i].lo.x() < f[j].lo.x(); });
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      const int i = order[a], j = order[b];
      if (f[j].lo.x() > f[i].hi.x() + tol) break;
      if (Find(parent, i) == Find(parent, j)) continue;
      if (OverlapOfSmaller(f[i], f[j], tol, cell) >= min_overlap) parent[Find(parent, i)] = Find(parent, j);
    }
  std::map<int, std::vector<int>> groups;
  for (int i = 0; i < n; ++i) groups[Find(parent, i)].push_back(i);
  std::vector<std::vector<int>> out;
  for (auto& [root, members] : groups) out.push_back(std::move(members));
  std::sort(out.begin(), out.end(), [](const auto& x, const auto& y) { return x.front() < y.front(); });
  return out;
}

}  // namespace rs
