#include "stages/georeference/road_plane.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <random>

namespace rs {
namespace {

// RANSAC then least squares on the inliers; nullopt-like (inliers = 0) when no plane qualifies.
RoadPlane FitOnePlane(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& cameras_mean,
                      const Eigen::Vector3d& axis, const RoadPlaneOptions& o, std::mt19937_64& rng) {
  RoadPlane best;
  best.points = static_cast<int>(pts.size());
  if (static_cast<int>(pts.size()) < o.min_inliers) return best;
  const double max_axis_dot = std::sin(o.max_axis_tilt_deg * M_PI / 180.0);
  std::uniform_int_distribution<size_t> pick(0, pts.size() - 1);
  int best_count = 0;
  Eigen::Vector3d best_n, best_p;
  for (int it = 0; it < o.ransac_iterations; ++it) {
    const Eigen::Vector3d& p0 = pts[pick(rng)];
    const Eigen::Vector3d n = (pts[pick(rng)] - p0).cross(pts[pick(rng)] - p0);
    if (n.norm() < 1e-9) continue;
    const Eigen::Vector3d nn = n.normalized();
    if (std::abs(nn.dot(axis)) > max_axis_dot) continue;
    int count = 0;
    for (const auto& p : pts) count += std::abs(nn.dot(p - p0)) <= o.tolerance_m;
    if (count > best_count) {
      best_count = count;
      best_n = nn;
      best_p = p0;
    }
  }
  if (best_count < o.min_inliers) return best;
  // Least-squares plane of the inliers (smallest principal axis), then its inliers' RMS.
  std::vector<Eigen::Vector3d> in;
  for (const auto& p : pts)
    if (std::abs(best_n.dot(p - best_p)) <= o.tolerance_m) in.push_back(p);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : in) mean += p;
  mean /= static_cast<double>(in.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : in) cov += (p - mean) * (p - mean).transpose();
  Eigen::Vector3d n = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0).normalized();
  if (n.dot(cameras_mean - mean) < 0) n = -n;  // the cameras are above the road
  double ss = 0;
  for (const auto& p : in) ss += std::pow(n.dot(p - mean), 2);
  best.up_slam = n;
  best.inliers = static_cast<int>(in.size());
  best.rms_m = std::sqrt(ss / static_cast<double>(in.size()));
  return best;
}

}  // namespace

std::vector<RoadPlane> FitRoadPlanes(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& cams,
                                     const Eigen::Vector3d& axis, const RoadPlaneOptions& o) {
  std::vector<RoadPlane> planes;
  if (cams.empty()) return planes;
  double lo = 1e300, hi = -1e300;
  for (const auto& c : cams) {
    lo = std::min(lo, c.dot(axis));
    hi = std::max(hi, c.dot(axis));
  }
  const int windows = std::max(1, static_cast<int>(std::ceil((hi - lo) / o.window_m)));
  const double step = (hi - lo) / windows;
  std::mt19937_64 rng(o.seed);
  for (int w = 0; w < windows; ++w) {
    const double a0 = lo + w * step, a1 = (w + 1 == windows) ? hi : a0 + step;
    std::vector<Eigen::Vector3d> window_cams;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& c : cams)
      if (c.dot(axis) >= a0 && c.dot(axis) <= a1) {
        window_cams.push_back(c);
        mean += c;
      }
    if (window_cams.empty()) continue;
    mean /= static_cast<double>(window_cams.size());
    std::vector<Eigen::Vector3d> pts;
    for (const auto& p : points) {
      double nearest = 1e300;
      for (const auto& c : window_cams) nearest = std::min(nearest, (p - c).squaredNorm());
      const double along = p.dot(axis);
      if (nearest <= o.max_range_m * o.max_range_m && along >= a0 - o.window_m / 2 && along <= a1 + o.window_m / 2)
        pts.push_back(p);
    }
    const RoadPlane plane = FitOnePlane(pts, mean, axis, o, rng);
    if (plane.inliers > 0) planes.push_back(plane);
  }
  return planes;
}

}  // namespace rs
