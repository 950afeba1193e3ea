#include "stages/georeference/gnss_fit.h"

#include <Eigen/SVD>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

namespace rs {
namespace {

// 1.4826 x median |x|: the Gaussian sigma of residual components, robust to outliers.
double RobustSigma(std::vector<double> abs_values) {
  if (abs_values.empty()) return 0;
  auto mid = abs_values.begin() + static_cast<std::ptrdiff_t>(abs_values.size() / 2);
  std::nth_element(abs_values.begin(), mid, abs_values.end());
  return 1.4826 * *mid;
}

double MaxAbsComponent(const Eigen::Vector3d& r) { return r.cwiseAbs().maxCoeff(); }

std::vector<Eigen::Vector3d> Residuals(const Similarity3& S, const std::vector<Eigen::Vector3d>& a,
                                       const std::vector<Eigen::Vector3d>& b) {
  std::vector<Eigen::Vector3d> r(a.size());
  for (size_t i = 0; i < a.size(); ++i) r[i] = b[i] - S.Apply(a[i]);
  return r;
}

// Best 3-point hypothesis by inlier count (ties: smaller squared error); the inlier mask.
std::vector<bool> RansacInliers(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                                const GnssFitOptions& o) {
  const size_t n = a.size();
  const double gate = o.outlier_sigmas * o.sigma_m;
  std::mt19937_64 rng(o.seed);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  std::vector<bool> best(n, true);
  int best_count = -1;
  double best_sse = 0;
  for (int it = 0; it < o.ransac_iterations; ++it) {
    const size_t i = pick(rng), j = pick(rng), k = pick(rng);
    if (i == j || j == k || i == k) continue;
    if ((a[i] - a[j]).norm() < 1e-6 || (a[j] - a[k]).norm() < 1e-6 || (a[i] - a[k]).norm() < 1e-6) continue;
    const Similarity3 S = WeightedUmeyama({a[i], a[j], a[k]}, {b[i], b[j], b[k]}, {1, 1, 1}, o.estimate_scale);
    std::vector<bool> mask(n);
    int count = 0;
    double sse = 0;
    for (size_t m = 0; m < n; ++m) {
      const Eigen::Vector3d r = b[m] - S.Apply(a[m]);
      mask[m] = MaxAbsComponent(r) <= gate;
      if (mask[m]) {
        ++count;
        sse += r.squaredNorm();
      }
    }
    if (count > best_count || (count == best_count && sse < best_sse)) {
      best_count = count;
      best_sse = sse;
      best = mask;
    }
  }
  if (best_count < 3) std::fill(best.begin(), best.end(), true);  // no consensus: let IRLS decide
  return best;
}

}  // namespace

Similarity3 WeightedUmeyama(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                            const std::vector<double>& w, bool with_scale) {
  double W = 0;
  Eigen::Vector3d ma = Eigen::Vector3d::Zero(), mb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) {
    W += w[i];
    ma += w[i] * a[i];
    mb += w[i] * b[i];
  }
  if (W <= 0) throw std::invalid_argument("WeightedUmeyama: all weights are zero");
  ma /= W;
  mb /= W;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var_a = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    cov += w[i] * (b[i] - mb) * (a[i] - ma).transpose();
    var_a += w[i] * (a[i] - ma).squaredNorm();
  }
  cov /= W;
  var_a /= W;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) D(2, 2) = -1;
  Similarity3 S;
  S.R = svd.matrixU() * D * svd.matrixV().transpose();
  if (with_scale && var_a > 0) S.scale = (svd.singularValues().asDiagonal() * D).trace() / var_a;
  S.t = mb - S.scale * S.R * ma;
  return S;
}

GnssFit FitSlamToGnss(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                      const GnssFitOptions& o) {
  if (a.size() != b.size()) throw std::invalid_argument("FitSlamToGnss: sample counts differ");
  if (a.size() < 3) throw std::invalid_argument("FitSlamToGnss: fewer than 3 GNSS fixes on the trajectory");
  const size_t n = a.size();
  GnssFit fit;
  fit.inlier = RansacInliers(a, b, o);
  fit.ransac_inliers = static_cast<int>(std::count(fit.inlier.begin(), fit.inlier.end(), true));
  fit.weight.assign(n, 0.0);
  for (size_t i = 0; i < n; ++i) fit.weight[i] = fit.inlier[i] ? 1.0 : 0.0;
  fit.transform = WeightedUmeyama(a, b, fit.weight, o.estimate_scale);

  // IRLS: Huber weights on the residual norm in per-axis sigmas (GNSS vertical is noisier), the outlier test
  // re-run every round so a fix wrongly rejected by RANSAC can come back.
  for (int round = 0; round < o.irls_iterations; ++round) {
    const auto r = Residuals(fit.transform, a, b);
    for (int k = 0; k < 3; ++k) {
      std::vector<double> comps;
      for (size_t i = 0; i < n; ++i)
        if (fit.inlier[i]) comps.push_back(std::abs(r[i][k]));
      fit.sigma_axis_m[k] = std::max(RobustSigma(comps), 1e-6);
    }
    fit.sigma_m = std::sqrt(fit.sigma_axis_m.squaredNorm() / 3);
    const double delta = o.huber_k * std::sqrt(3.0);
    int kept = 0;
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d z = r[i].cwiseQuotient(fit.sigma_axis_m);  // residual in sigmas per axis
      fit.inlier[i] = MaxAbsComponent(z) <= o.outlier_sigmas;
      const double norm = z.norm();
      fit.weight[i] = !fit.inlier[i] ? 0.0 : norm <= delta ? 1.0 : delta / norm;
      kept += fit.inlier[i];
    }
    if (kept < 3) throw std::invalid_argument("FitSlamToGnss: fewer than 3 GNSS fixes agree with the trajectory");
    fit.transform = WeightedUmeyama(a, b, fit.weight, o.estimate_scale);
  }

  // The track's main direction and what positions say about the rotation about it.
  double W = 0;
  Eigen::Vector3d ma = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    W += fit.weight[i];
    ma += fit.weight[i] * a[i];
  }
  ma /= W;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double spread = 0;
  for (size_t i = 0; i < n; ++i) {
    cov += fit.weight[i] * (a[i] - ma) * (a[i] - ma).transpose();
    spread += fit.weight[i] * (a[i] - ma).squaredNorm();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  fit.axis_slam = eig.eigenvectors().col(2).normalized();
  double off_axis = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d d = a[i] - ma;
    off_axis += fit.weight[i] * (d - d.dot(fit.axis_slam) * fit.axis_slam).squaredNorm();
  }
  const double s2 = fit.transform.scale * fit.transform.scale;
  fit.roll_information = s2 * off_axis / (fit.sigma_m * fit.sigma_m);
  if (o.estimate_scale) fit.scale_sigma = fit.sigma_m / std::sqrt(std::max(spread, 1e-12));
  return fit;
}

RollEstimate RollAboutTrackAxis(const std::vector<Eigen::Vector3d>& up_slam, const std::vector<Eigen::Vector3d>& a,
                                GnssFit& fit) {
  RollEstimate est;
  Similarity3& S = fit.transform;
  const Eigen::Vector3d d = (S.R * fit.axis_slam).normalized();
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  // Angle about d maximising z . R(theta) U (closed form for a rotation about a fixed axis).
  auto angle_for = [&](const Eigen::Vector3d& U) {
    return std::atan2(z.dot(d.cross(U)), z.dot(U) - d.dot(z) * d.dot(U));
  };
  Eigen::Vector3d U = Eigen::Vector3d::Zero();
  for (const auto& u : up_slam) U += (S.R * u).normalized();
  est.observations = static_cast<int>(up_slam.size());
  if (up_slam.empty()) return est;
  est.angle_rad = angle_for(U);
  double ss = 0;
  for (const auto& u : up_slam) ss += std::pow(std::remainder(angle_for((S.R * u).normalized()) - est.angle_rad, 2 * M_PI), 2);
  const int nobs = est.observations;
  est.sigma_rad = nobs > 1 ? std::sqrt(ss / (nobs - 1) / nobs) : 0.0;
  const double info = est.sigma_rad > 0 ? 1.0 / (est.sigma_rad * est.sigma_rad) : 1e30;
  est.weight = info / (info + fit.roll_information);
  est.applied_rad = est.weight * est.angle_rad;

  // Rotate about d through the fitted weighted centroid (the positions' fit there is unchanged).
  double W = 0;
  Eigen::Vector3d ma = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) {
    W += fit.weight[i];
    ma += fit.weight[i] * a[i];
  }
  ma /= W;
  const Eigen::Vector3d centre_enu = S.Apply(ma);
  S.R = Eigen::AngleAxisd(est.applied_rad, d).toRotationMatrix() * S.R;
  S.t = centre_enu - S.scale * S.R * ma;
  return est;
}

}  // namespace rs
