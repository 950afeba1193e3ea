#include "eval/trajectory/trajectory_metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <tuple>

#include <Eigen/SVD>
#include <fmt/format.h>

#include "formats/input_error.h"

namespace rs {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

void AddPair(PosePairs* out, const Trajectory& est, size_t i, const Trajectory& gt, size_t j) {
  out->t_ns.push_back(est.poses[i].t_ns);
  out->est_index.push_back(i);
  out->gt_index.push_back(j);
  out->est.push_back(est.poses[i].T_world_frame);
  out->gt.push_back(gt.poses[j].T_world_frame);
}

/// Index of the pose in `t` (sorted) nearest to `query`.
size_t Nearest(const std::vector<int64_t>& t, int64_t query) {
  const auto it = std::lower_bound(t.begin(), t.end(), query);
  if (it == t.begin()) return 0;
  if (it == t.end()) return t.size() - 1;
  const size_t hi = static_cast<size_t>(it - t.begin());
  // Compare as unsigned differences of ordered values: no overflow for any int64 pair.
  const uint64_t d_hi = static_cast<uint64_t>(t[hi]) - static_cast<uint64_t>(query);
  const uint64_t d_lo = static_cast<uint64_t>(query) - static_cast<uint64_t>(t[hi - 1]);
  size_t k = d_lo <= d_hi ? hi - 1 : hi;
  while (k > 0 && t[k] == t[k - 1]) --k;  // a repeated time: only the first pose of the run may match
  return k;
}

uint64_t AbsDiff(int64_t a, int64_t b) {
  return a >= b ? static_cast<uint64_t>(a) - static_cast<uint64_t>(b)
                : static_cast<uint64_t>(b) - static_cast<uint64_t>(a);
}

void RequireTimes(const Trajectory& t) {
  if (!t.has_times) {
    throw InputError(InputLocation::File(t.source),
                     "trajectory has no timestamps (KITTI poses without times.txt): associate by index instead");
  }
}

}  // namespace

std::optional<TrajectoryAlignment> ParseTrajectoryAlignment(std::string_view name) {
  if (name == "none") return TrajectoryAlignment::kNone;
  if (name == "se3") return TrajectoryAlignment::kSE3;
  if (name == "sim3") return TrajectoryAlignment::kSim3;
  return std::nullopt;
}

const char* TrajectoryAlignmentName(TrajectoryAlignment alignment) {
  switch (alignment) {
    case TrajectoryAlignment::kNone: return "none";
    case TrajectoryAlignment::kSE3: return "se3";
    case TrajectoryAlignment::kSim3: return "sim3";
  }
  return "?";
}

Sim3Transform UmeyamaAlignment(const Eigen::Matrix3Xd& est, const Eigen::Matrix3Xd& gt, TrajectoryAlignment alignment) {
  if (est.cols() != gt.cols()) {
    throw std::invalid_argument(
        fmt::format("alignment: {} estimate vs {} ground-truth positions", est.cols(), gt.cols()));
  }
  if (alignment == TrajectoryAlignment::kNone) return {};
  const Eigen::Index n = est.cols();
  if (n < 3) throw std::invalid_argument(fmt::format("alignment needs at least 3 matched poses, got {}", n));
  const Eigen::Vector3d mu_est = est.rowwise().mean();
  const Eigen::Vector3d mu_gt = gt.rowwise().mean();
  const Eigen::Matrix3Xd e = est.colwise() - mu_est;
  const Eigen::Matrix3Xd g = gt.colwise() - mu_gt;
  const Eigen::Matrix3d sigma = g * e.transpose() / static_cast<double>(n);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  // Rank < 2: the points lie on a line (or a point) in one of the trajectories; any rotation about it fits.
  if (!(d[1] > 1e-12 * d[0]) || !(d[0] > 0)) {
    throw std::invalid_argument("alignment: matched positions are collinear or coincident, rotation undetermined");
  }
  Eigen::Vector3d s(1, 1, 1);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) s[2] = -1;  // no reflections
  Sim3Transform T;
  T.R = svd.matrixU() * s.asDiagonal() * svd.matrixV().transpose();
  if (alignment == TrajectoryAlignment::kSim3) {
    const double var_est = e.squaredNorm() / static_cast<double>(n);
    T.scale = d.dot(s) / var_est;
  }
  T.t = mu_gt - T.scale * T.R * mu_est;
  return T;
}

PosePairs AssociateByTimestamp(const Trajectory& est, const Trajectory& gt, int64_t max_difference_ns,
                               int64_t est_offset_ns) {
  RequireTimes(est);
  RequireTimes(gt);
  if (max_difference_ns < 0) throw std::invalid_argument("association: max time difference must be >= 0");
  std::vector<int64_t> te(est.poses.size()), tg(gt.poses.size());
  for (size_t i = 0; i < te.size(); ++i) {
    if (__builtin_add_overflow(est.poses[i].t_ns, est_offset_ns, &te[i])) {
      throw std::invalid_argument("association: time offset pushes estimate times outside int64 ns");
    }
  }
  for (size_t j = 0; j < tg.size(); ++j) tg[j] = gt.poses[j].t_ns;
  PosePairs out;
  if (te.empty() || tg.empty()) return out;

  struct Candidate {
    uint64_t diff;
    size_t i, j;
  };
  std::vector<Candidate> candidates;
  auto consider = [&](size_t i, size_t j) {
    const uint64_t diff = AbsDiff(te[i], tg[j]);
    if (diff <= static_cast<uint64_t>(max_difference_ns)) candidates.push_back({diff, i, j});
  };
  for (size_t i = 0; i < te.size(); ++i) {
    if (i == 0 || te[i] != te[i - 1]) consider(i, Nearest(tg, te[i]));
  }
  for (size_t j = 0; j < tg.size(); ++j) {
    if (j == 0 || tg[j] != tg[j - 1]) consider(Nearest(te, tg[j]), j);
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.diff, a.i, a.j) < std::tie(b.diff, b.i, b.j);
  });
  std::vector<size_t> gt_of_est(te.size(), SIZE_MAX);
  std::vector<char> gt_used(tg.size(), 0);
  for (const Candidate& c : candidates) {
    if (gt_of_est[c.i] != SIZE_MAX || gt_used[c.j]) continue;
    gt_of_est[c.i] = c.j;
    gt_used[c.j] = 1;
  }
  // Both trajectories are time-ordered, so pairs in estimate order are also in ground-truth order.
  for (size_t i = 0; i < te.size(); ++i) {
    if (gt_of_est[i] != SIZE_MAX) AddPair(&out, est, i, gt, gt_of_est[i]);
  }
  return out;
}

PosePairs AssociateByIndex(const Trajectory& est, const Trajectory& gt) {
  if (est.poses.size() != gt.poses.size()) {
    throw InputError(InputLocation::File(est.source),
                     fmt::format("association by index needs equal pose counts: {} poses here, {} in {}",
                                 est.poses.size(), gt.poses.size(), gt.source));
  }
  PosePairs out;
  for (size_t i = 0; i < est.poses.size(); ++i) AddPair(&out, est, i, gt, i);
  return out;
}

ErrorStats ComputeErrorStats(std::vector<double> e) {
  ErrorStats s;
  s.count = e.size();
  if (e.empty()) return s;
  const double n = static_cast<double>(e.size());
  double sum = 0, sum_sq = 0;
  for (double v : e) sum += v, sum_sq += v * v;
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0;
  for (double v : e) var += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(var / n);
  const auto [lo, hi] = std::minmax_element(e.begin(), e.end());
  s.min = *lo;
  s.max = *hi;
  const size_t mid = e.size() / 2;
  std::nth_element(e.begin(), e.begin() + mid, e.end());
  s.median = e[mid];
  if (e.size() % 2 == 0) s.median = 0.5 * (s.median + *std::max_element(e.begin(), e.begin() + mid));
  return s;
}

double RotationAngleRad(const Eigen::Matrix3d& R) {
  // atan2 of sin and cos of the angle: accurate at small angles where acos((tr - 1) / 2) loses digits.
  const double c = 0.5 * (R.trace() - 1.0);
  const Eigen::Vector3d w(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * w.norm(), c);
}

AteResult ComputeAte(const PosePairs& pairs, TrajectoryAlignment alignment) {
  const size_t n = pairs.size();
  Eigen::Matrix3Xd est(3, n), gt(3, n);
  for (size_t i = 0; i < n; ++i) {
    est.col(i) = pairs.est[i].translation();
    gt.col(i) = pairs.gt[i].translation();
  }
  AteResult r;
  r.alignment = UmeyamaAlignment(est, gt, alignment);
  r.errors_m.resize(n);
  std::vector<double> rot(n);
  for (size_t i = 0; i < n; ++i) {
    r.errors_m[i] = (gt.col(i) - r.alignment.Apply(est.col(i))).norm();
    rot[i] = RotationAngleRad(pairs.gt[i].linear().transpose() * r.alignment.R * pairs.est[i].linear()) * kRadToDeg;
  }
  r.translation_m = ComputeErrorStats(r.errors_m);
  r.rotation_deg = ComputeErrorStats(std::move(rot));
  return r;
}

std::vector<std::pair<size_t, size_t>> RelativePairs(const PosePairs& pairs, const RelativeDelta& delta) {
  if (!(delta.value > 0) || !std::isfinite(delta.value)) {
    throw std::invalid_argument(fmt::format("relative delta = {} violates delta > 0", delta.value));
  }
  std::vector<std::pair<size_t, size_t>> out;
  const size_t n = pairs.size();
  switch (delta.unit) {
    case RelativeDelta::Unit::kFrames: {
      if (delta.value != std::floor(delta.value)) {
        throw std::invalid_argument(fmt::format("relative delta = {} frames must be a whole number", delta.value));
      }
      const double step = delta.value;
      for (size_t i = 0; static_cast<double>(i) + step < static_cast<double>(n); ++i) {
        out.emplace_back(i, i + static_cast<size_t>(step));
      }
      break;
    }
    case RelativeDelta::Unit::kSeconds: {
      if (delta.value > 9e9) break;  // beyond the int64 ns range: no pair can exist
      const int64_t delta_ns = std::llround(delta.value * 1e9);
      for (size_t i = 0; i < n; ++i) {
        int64_t target = 0;
        if (__builtin_add_overflow(pairs.t_ns[i], delta_ns, &target) || target > pairs.t_ns.back()) break;
        const size_t j = Nearest(pairs.t_ns, target);
        if (j > i) out.emplace_back(i, j);
      }
      break;
    }
    case RelativeDelta::Unit::kMeters: {
      std::vector<double> dist(n, 0.0);
      for (size_t k = 1; k < n; ++k) {
        dist[k] = dist[k - 1] + (pairs.gt[k].translation() - pairs.gt[k - 1].translation()).norm();
      }
      size_t j = 0;
      for (size_t i = 0; i < n; ++i) {
        j = std::max(j, i + 1);
        while (j < n && dist[j] - dist[i] < delta.value) ++j;
        if (j >= n) break;
        out.emplace_back(i, j);
      }
      break;
    }
  }
  return out;
}

RdeResult ComputeRde(const PosePairs& pairs, const RelativeDelta& delta, double scale) {
  RdeResult r;
  for (const auto& [i, j] : RelativePairs(pairs, delta)) {
    const double d_est = scale * (pairs.est[j].translation() - pairs.est[i].translation()).norm();
    const double d_gt = (pairs.gt[j].translation() - pairs.gt[i].translation()).norm();
    r.errors_m.push_back(std::abs(d_est - d_gt));
  }
  r.stats_m = ComputeErrorStats(r.errors_m);
  return r;
}

namespace {

/// Relative motion from pose i to pose j with the translation scaled by s.
Eigen::Isometry3d Delta(const Eigen::Isometry3d& Ti, const Eigen::Isometry3d& Tj, double s) {
  Eigen::Isometry3d D = Ti.inverse() * Tj;
  D.translation() *= s;
  return D;
}

}  // namespace

RpeResult ComputeRpe(const PosePairs& pairs, const RelativeDelta& delta, double scale) {
  RpeResult r;
  for (const auto& [i, j] : RelativePairs(pairs, delta)) {
    const Eigen::Isometry3d E =
        Delta(pairs.gt[i], pairs.gt[j], 1.0).inverse() * Delta(pairs.est[i], pairs.est[j], scale);
    r.translation_m.push_back(E.translation().norm());
    r.rotation_deg.push_back(RotationAngleRad(E.linear()) * kRadToDeg);
  }
  r.translation_stats_m = ComputeErrorStats(r.translation_m);
  r.rotation_stats_deg = ComputeErrorStats(r.rotation_deg);
  return r;
}

KittiOdometryResult ComputeKittiOdometry(const PosePairs& pairs, const KittiOdometryOptions& options, double scale) {
  if (options.step_frames < 1) {
    throw std::invalid_argument(fmt::format("kitti step_frames = {} violates step_frames >= 1", options.step_frames));
  }
  for (double L : options.lengths_m) {
    if (!(L > 0) || !std::isfinite(L))
      throw std::invalid_argument(fmt::format("kitti length {} m violates length > 0", L));
  }
  const size_t n = pairs.size();
  std::vector<double> dist(n, 0.0);
  for (size_t k = 1; k < n; ++k)
    dist[k] = dist[k - 1] + (pairs.gt[k].translation() - pairs.gt[k - 1].translation()).norm();
  const double total_m = n ? dist.back() : 0.0;

  KittiOdometryResult r;
  r.used_lengths_m = options.lengths_m;
  const bool any_fits =
      std::any_of(r.used_lengths_m.begin(), r.used_lengths_m.end(), [&](double L) { return L < total_m; });
  if (!any_fits && options.shorten_for_short_sequences && total_m > 0) {
    r.used_lengths_m.clear();
    for (int k = 1; k <= 8; ++k) r.used_lengths_m.push_back(total_m * k / 10.0);
  }

  double t_sum = 0, r_sum = 0;
  for (double L : r.used_lengths_m) {
    KittiOdometryResult::PerLength per;
    per.length_m = L;
    size_t last = 0;
    for (size_t first = 0; first < n; first += static_cast<size_t>(options.step_frames)) {
      // The devkit's lastFrameFromSegmentLength: first frame strictly beyond L of travel.
      last = std::max(last, first);
      while (last < n && !(dist[last] > dist[first] + L)) ++last;
      if (last >= n) break;
      const Eigen::Isometry3d E =
          Delta(pairs.est[first], pairs.est[last], scale).inverse() * Delta(pairs.gt[first], pairs.gt[last], 1.0);
      const double t_err = E.translation().norm() / L;
      const double r_err = RotationAngleRad(E.linear()) / L;
      per.segments++;
      per.t_err_percent += t_err;
      per.r_err_deg_per_100m += r_err;
      t_sum += t_err;
      r_sum += r_err;
    }
    if (per.segments == 0) continue;
    r.segments += per.segments;
    per.t_err_percent = per.t_err_percent / per.segments * 100.0;
    per.r_err_deg_per_100m = per.r_err_deg_per_100m / per.segments * kRadToDeg * 100.0;
    r.per_length.push_back(per);
  }
  if (r.segments > 0) {
    r.t_err_percent = t_sum / r.segments * 100.0;
    r.r_err_deg_per_100m = r_sum / r.segments * kRadToDeg * 100.0;
  }
  return r;
}

}  // namespace rs
