#include "stages/slam/pose_optimizer.h"

#include <cmath>

namespace rs {

Eigen::Isometry3d ExpSe3Left(const Eigen::Matrix<double, 6, 1>& delta, const Eigen::Isometry3d& T) {
  const Eigen::Vector3d w = delta.head<3>(), u = delta.tail<3>();
  const double theta = w.norm();
  Eigen::Matrix3d W;
  W << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  Eigen::Matrix3d R, V;
  if (theta < 1e-10) {
    R = Eigen::Matrix3d::Identity() + W;
    V = Eigen::Matrix3d::Identity() + 0.5 * W;
  } else {
    const double a = std::sin(theta) / theta, b = (1 - std::cos(theta)) / (theta * theta),
                 c = (theta - std::sin(theta)) / (theta * theta * theta);
    R = Eigen::Matrix3d::Identity() + a * W + b * W * W;
    V = Eigen::Matrix3d::Identity() + b * W + c * W * W;
  }
  Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
  D.linear() = R;
  D.translation() = V * u;
  Eigen::Isometry3d out = D * T;
  // Re-orthonormalise so that many small updates do not drift off SO(3).
  Eigen::Quaterniond q(out.linear());
  q.normalize();
  out.linear() = q.toRotationMatrix();
  return out;
}

int OptimizePose(const RectifiedStereo& cam, std::vector<PoseObservation>* obs, Eigen::Isometry3d* T_cam_world) {
  if (obs->size() < 3) return 0;
  const double delta_mono = std::sqrt(kChi2Mono), delta_stereo = std::sqrt(kChi2Stereo);
  for (auto& o : *obs) o.outlier = false;
  Eigen::Isometry3d T = *T_cam_world;
  int inliers = 0;
  constexpr int kRounds = 4, kIterations = 10;
  for (int round = 0; round < kRounds; ++round) {
    const bool robust = round < kRounds - 1;
    for (int it = 0; it < kIterations; ++it) {
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      int used = 0;
      for (const auto& o : *obs) {
        if (o.outlier) continue;
        const Eigen::Vector3d pc = T * o.p_world;
        if (pc.z() <= 1e-6) continue;
        const double iz = 1.0 / pc.z(), x = pc.x(), y = pc.y();
        const bool stereo = o.u_right >= 0;
        Eigen::Matrix<double, 3, 3> Jp;  // d(u, v, ur)/d pc
        Jp << cam.f_px * iz, 0, -cam.f_px * x * iz * iz, 0, cam.f_px * iz, -cam.f_px * y * iz * iz, cam.f_px * iz, 0,
            -cam.f_px * (x - cam.baseline_m) * iz * iz;
        Eigen::Matrix<double, 3, 6> Jt;  // d pc / d delta (left perturbation: [-pc]x, I)
        Jt << 0, pc.z(), -pc.y(), 1, 0, 0, -pc.z(), 0, pc.x(), 0, 1, 0, pc.y(), -pc.x(), 0, 0, 0, 1;
        Eigen::Vector3d r(o.u - (cam.f_px * x * iz + cam.cx_px), o.v - (cam.f_px * y * iz + cam.cy_px), 0);
        if (stereo) r.z() = o.u_right - (cam.f_px * (x - cam.baseline_m) * iz + cam.cx_px);
        const int dim = stereo ? 3 : 2;
        const Eigen::Matrix<double, 3, 6> J = -Jp * Jt;  // residual = measured - predicted
        const double chi2 = r.head(dim).squaredNorm() * o.inv_sigma2;
        double w = o.inv_sigma2;
        if (robust) {
          const double e = std::sqrt(chi2), d = stereo ? delta_stereo : delta_mono;
          if (e > d) w *= d / e;
        }
        H += w * J.topRows(dim).transpose() * J.topRows(dim);
        g -= w * J.topRows(dim).transpose() * r.head(dim);
        ++used;
      }
      if (used < 3) break;
      const Eigen::Matrix<double, 6, 1> delta = H.ldlt().solve(g);
      if (!delta.allFinite()) break;
      T = ExpSe3Left(delta, T);
      if (delta.squaredNorm() < 1e-12) break;
    }
    // Classify every observation (outliers of earlier rounds may come back).
    inliers = 0;
    for (auto& o : *obs) {
      const Eigen::Vector3d pc = T * o.p_world;
      if (pc.z() <= 1e-6) {
        o.outlier = true;
        continue;
      }
      const double iz = 1.0 / pc.z();
      double e2 = std::pow(o.u - (cam.f_px * pc.x() * iz + cam.cx_px), 2) +
                  std::pow(o.v - (cam.f_px * pc.y() * iz + cam.cy_px), 2);
      const bool stereo = o.u_right >= 0;
      if (stereo) e2 += std::pow(o.u_right - (cam.f_px * (pc.x() - cam.baseline_m) * iz + cam.cx_px), 2);
      o.outlier = e2 * o.inv_sigma2 > (stereo ? kChi2Stereo : kChi2Mono);
      if (!o.outlier) ++inliers;
    }
    if (inliers < 10) break;
  }
  *T_cam_world = T;
  return inliers;
}

}  // namespace rs
