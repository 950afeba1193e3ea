#include "stages/refine/gauge.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/SVD>

namespace rs {
namespace {

Eigen::Matrix3d Hat(const Eigen::Vector3d& w) {
  Eigen::Matrix3d W;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return W;
}

// Left Jacobian of SO(3): V in t = V rho.
Eigen::Matrix3d LeftJacobian(const Eigen::Vector3d& phi) {
  const double a = phi.norm();
  const Eigen::Matrix3d W = Hat(phi);
  if (a < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * W + W * W / 6.0;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(a)) / (a * a) * W + (a - std::sin(a)) / (a * a * a) * W * W;
}

}  // namespace

Eigen::Matrix<double, 6, 1> LogSE3(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd aa(T.linear());
  const Eigen::Vector3d phi = aa.angle() * aa.axis();
  Eigen::Matrix<double, 6, 1> xi;
  xi.head<3>() = LeftJacobian(phi).inverse() * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

Eigen::Isometry3d ExpSE3(const Eigen::Matrix<double, 6, 1>& xi) {
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double a = phi.norm();
  T.linear() = a < 1e-12 ? Eigen::Matrix3d::Identity() : Eigen::AngleAxisd(a, phi / a).toRotationMatrix();
  T.translation() = LeftJacobian(phi) * xi.head<3>();
  return T;
}

Eigen::Isometry3d GaugeTransform(const std::vector<Eigen::Isometry3d>& slam,
                                 const std::vector<Eigen::Isometry3d>& refined, GaugeAnchor anchor) {
  if (slam.empty() || slam.size() != refined.size()) throw std::invalid_argument("gauge: one refined pose per SLAM pose");
  if (anchor == GaugeAnchor::kFirstKeyframe) return slam.front() * refined.front().inverse();
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d c_slam = Eigen::Vector3d::Zero(), c_ref = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < slam.size(); ++i) {
    sum += slam[i].linear() * refined[i].linear().transpose();
    c_slam += slam[i].translation();
    c_ref += refined[i].translation();
  }
  c_slam /= double(slam.size());
  c_ref /= double(slam.size());
  // Chordal L2 mean: the rotation nearest (Frobenius) to the summed rotations.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  Eigen::Isometry3d G = Eigen::Isometry3d::Identity();
  G.linear() = svd.matrixU() * D * svd.matrixV().transpose();
  G.translation() = c_slam - G.linear() * c_ref;
  return G;
}

Trajectory CarryTrajectory(const Trajectory& slam, std::vector<KeyframeCorrection> corr) {
  if (corr.empty()) throw std::invalid_argument("carry: no keyframe correction");
  // In-place sort: stable_sort's temporary buffer ignores the over-alignment Eigen's Isometry3d
  // needs under AVX (-march=native) and the vectorised copies into it fault.
  std::sort(corr.begin(), corr.end(), [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });
  Trajectory out = slam;
  for (StampedPose& pose : out.poses) {
    const auto after = std::lower_bound(corr.begin(), corr.end(), pose.t_ns,
                                        [](const KeyframeCorrection& k, int64_t t) { return k.t_ns < t; });
    Eigen::Isometry3d C;
    if (after == corr.begin()) {
      C = corr.front().C;
    } else if (after == corr.end()) {
      C = corr.back().C;
    } else if (after->t_ns == pose.t_ns) {
      C = after->C;
    } else {
      const KeyframeCorrection& k0 = *(after - 1);
      const KeyframeCorrection& k1 = *after;
      const double a = double(pose.t_ns - k0.t_ns) / double(k1.t_ns - k0.t_ns);
      C = k0.C * ExpSE3(a * LogSE3(k0.C.inverse() * k1.C));
    }
    pose.T_world_frame = C * pose.T_world_frame;
  }
  return out;
}

}  // namespace rs
