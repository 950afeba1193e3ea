#include "stages/slam/bundle_adjust.h"

#include <algorithm>
#include <array>
#include <map>
#include <set>

#include <ceres/ceres.h>

#include "stages/slam/bundle_adjust_solver.h"
#include "stages/slam/pose_optimizer.h"

namespace rs {
namespace {

std::array<double, 6> ToParams(const Eigen::Isometry3d& T) {
  std::array<double, 6> p{};
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(T.linear()));
  const Eigen::Vector3d v = aa.angle() * aa.axis();
  p = {v.x(), v.y(), v.z(), T.translation().x(), T.translation().y(), T.translation().z()};
  return p;
}

Eigen::Isometry3d FromParams(const std::array<double, 6>& p) {
  const Eigen::Vector3d v(p[0], p[1], p[2]);
  const double angle = v.norm();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (angle > 1e-15) T.linear() = Eigen::AngleAxisd(angle, v / angle).toRotationMatrix();
  T.translation() = Eigen::Vector3d(p[3], p[4], p[5]);
  return T;
}

double ObservationChi2(const RectifiedStereo& cam, const Keyframe& kf, int feat, const Eigen::Vector3d& p_world,
                       const ScalePyramid& pyramid, bool* stereo) {
  const cv::KeyPoint& kp = kf.features.keypoints[feat];
  const Eigen::Vector3d pc = kf.T_cam_world * p_world;
  *stereo = kf.features.u_right[feat] >= 0;
  if (pc.z() <= 1e-6) return 1e9;
  const double iz = 1.0 / pc.z();
  double e2 = std::pow(kp.pt.x - (cam.f_px * pc.x() * iz + cam.cx_px), 2) +
              std::pow(kp.pt.y - (cam.f_px * pc.y() * iz + cam.cy_px), 2);
  if (*stereo) e2 += std::pow(kf.features.u_right[feat] - (cam.f_px * (pc.x() - cam.baseline_m) * iz + cam.cx_px), 2);
  return e2 * pyramid.inv_sigma2[kp.octave];
}

// ceres::CostFunction over EvaluateReprojection.
class ReprojectionCost : public ceres::SizedCostFunction<3, 6, 3> {
 public:
  explicit ReprojectionCost(const ReprojectionResidual& r) : r_(r) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    EvaluateReprojection(r_, parameters[0], parameters[1], residuals, jacobians ? jacobians[0] : nullptr,
                         jacobians ? jacobians[1] : nullptr);
    return true;
  }

 private:
  ReprojectionResidual r_;
};

}  // namespace

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

void AngleAxisWithLeftJacobian(const Eigen::Vector3d& w, Eigen::Matrix3d* R, Eigen::Matrix3d* Jl) {
  const double theta2 = w.squaredNorm();
  const Eigen::Matrix3d W = Skew(w);
  if (theta2 > 1e-16) {
    const double theta = std::sqrt(theta2);
    *R = Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
    *Jl = Eigen::Matrix3d::Identity() + (1 - std::cos(theta)) / theta2 * W +
          (theta - std::sin(theta)) / (theta2 * theta) * W * W;
  } else {
    *R = Eigen::Matrix3d::Identity() + W;
    *Jl = Eigen::Matrix3d::Identity() + 0.5 * W;
  }
}

PoseRotation::PoseRotation(const double* pose) {
  AngleAxisWithLeftJacobian(Eigen::Map<const Eigen::Vector3d>(pose), &R, &Jl);
}

void EvaluateReprojection(const ReprojectionResidual& r, const double* pose, const double* point, double* residual,
                          double* J_pose, double* J_point) {
  EvaluateReprojection(r, PoseRotation(pose), pose + 3, point, residual, J_pose, J_point);
}

void EvaluateReprojection(const ReprojectionResidual& r, const PoseRotation& rotation, const double* translation,
                          const double* point, double* residual, double* J_pose, double* J_point) {
  // Rotation and its left Jacobian: d(R(w) x)/dw = -[R x]_x Jl(w).
  const Eigen::Matrix3d &R = rotation.R, &Jl = rotation.Jl;
  const Eigen::Map<const Eigen::Vector3d> t(translation), x(point);
  const Eigen::Vector3d Rx = R * x, pc = Rx + t;
  const double iz = 1.0 / pc.z(), s = r.sqrt_info;
  const bool stereo = r.u_right >= 0;
  residual[0] = (r.fx * pc.x() * iz + r.cx - r.u) * s;
  residual[1] = (r.fy * pc.y() * iz + r.cy - r.v) * s;
  residual[2] = stereo ? (r.fx * (pc.x() - r.baseline_m) * iz + r.cx - r.u_right) * s : 0.0;
  if (!J_pose && !J_point) return;
  Eigen::Matrix3d D;                            // d(residual)/d(pc)
  D << r.fx * iz, 0, -r.fx * pc.x() * iz * iz,  //
      0, r.fy * iz, -r.fy * pc.y() * iz * iz,   //
      r.fx * iz, 0, -r.fx * (pc.x() - r.baseline_m) * iz * iz;
  if (!stereo) D.row(2).setZero();
  D *= s;
  if (J_pose) {
    Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> J(J_pose);
    J.leftCols<3>() = -D * Skew(Rx) * Jl;
    J.rightCols<3>() = D;
  }
  if (J_point) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(J_point);
    J = D * R;
  }
}

BundleAdjustSummary BundleAdjust(SlamMap* map, const std::vector<int>& free_kfs, const RectifiedStereo& cam,
                                 const ScalePyramid& pyramid, int iterations, bool remove_outliers,
                                 const std::vector<int>& fixed_kfs_extra, bool fixed_size) {
  BundleAdjustSummary summary;
  std::set<int> free_set;
  for (int k : free_kfs)
    if (!map->keyframes[k].bad) free_set.insert(k);
  std::set<int> point_set;
  for (int k : free_set)
    for (int p : map->keyframes[k].points)
      if (p >= 0 && !map->points[p].bad) point_set.insert(p);
  std::set<int> fixed_set(fixed_kfs_extra.begin(), fixed_kfs_extra.end());
  for (int p : point_set)
    for (auto& [k, f] : map->points[p].observations)
      if (!free_set.count(k)) fixed_set.insert(k);
  // Without a fixed keyframe the gauge is free: hold the oldest free one.
  if (fixed_set.empty() && !free_set.empty()) {
    fixed_set.insert(*free_set.begin());
    free_set.erase(free_set.begin());
  }
  std::map<int, std::array<double, 6>> poses;
  for (int k : free_set) poses[k] = ToParams(map->keyframes[k].T_cam_world);
  for (int k : fixed_set) poses[k] = ToParams(map->keyframes[k].T_cam_world);
  std::map<int, std::array<double, 3>> pts;
  for (int p : point_set) {
    const Eigen::Vector3d& x = map->points[p].p_world;
    pts[p] = {x.x(), x.y(), x.z()};
  }

  auto solve = [&](int max_iterations) {
    // A local window has a handful of keyframes: its reduced camera system is small and dense
    // (bundle_adjust_solver.h: fixed-size blocks, ~5x less CPU than Ceres' generic DENSE_SCHUR here).
    if (fixed_size && poses.size() <= 40) {
      SmallBundleProblem sp;
      std::map<int, int> pose_index;
      for (auto& [k, x] : poses) {
        pose_index[k] = static_cast<int>(sp.poses.size());
        sp.poses.push_back(x);
        sp.pose_fixed.push_back(fixed_set.count(k) ? 1 : 0);
      }
      std::vector<int> point_ids;
      for (int p : point_set) {
        const int q = static_cast<int>(sp.points.size());
        sp.points.push_back(pts[p]);
        point_ids.push_back(p);
        for (auto& [k, f] : map->points[p].observations) {
          const Keyframe& kf = map->keyframes[k];
          const cv::KeyPoint& kp = kf.features.keypoints[f];
          SmallBundleObservation o;
          o.pose = pose_index.at(k);
          o.point = q;
          o.r = ReprojectionResidual{kp.pt.x,   kp.pt.y,        kf.features.u_right[f],
                                     cam.f_px,  cam.f_px,       cam.cx_px,
                                     cam.cy_px, cam.baseline_m, 1.0 / pyramid.scale[kp.octave]};
          o.huber = std::sqrt(o.r.u_right >= 0 ? kChi2Stereo : kChi2Mono);
          sp.observations.push_back(o);
        }
      }
      const SmallBundleSummary s = SolveSmallBundle(&sp, max_iterations);
      for (auto& [k, x] : poses) x = sp.poses[pose_index.at(k)];
      for (size_t q = 0; q < point_ids.size(); ++q) pts[point_ids[q]] = sp.points[q];
      summary.observations = static_cast<int>(sp.observations.size());
      if (summary.initial_cost == 0) summary.initial_cost = s.initial_cost;
      summary.final_cost = s.final_cost;
      return;
    }
    ceres::Problem problem;  // owns (reference-counted) the shared loss functions below
    ceres::LossFunction* ls = new ceres::HuberLoss(std::sqrt(kChi2Stereo));
    ceres::LossFunction* lm = new ceres::HuberLoss(std::sqrt(kChi2Mono));
    int obs = 0;
    bool used_stereo = false, used_mono = false;
    for (int p : point_set) {
      for (auto& [k, f] : map->points[p].observations) {
        const Keyframe& kf = map->keyframes[k];
        const cv::KeyPoint& kp = kf.features.keypoints[f];
        ReprojectionResidual r{kp.pt.x,   kp.pt.y,        kf.features.u_right[f],        cam.f_px, cam.f_px, cam.cx_px,
                               cam.cy_px, cam.baseline_m, 1.0 / pyramid.scale[kp.octave]};
        auto* cost = new ReprojectionCost(r);
        (r.u_right >= 0 ? used_stereo : used_mono) = true;
        problem.AddResidualBlock(cost, r.u_right >= 0 ? ls : lm, poses[k].data(), pts[p].data());
        ++obs;
      }
    }
    for (int k : fixed_set)
      if (problem.HasParameterBlock(poses[k].data())) problem.SetParameterBlockConstant(poses[k].data());
    ceres::Solver::Options options;
    // A local window has a handful of keyframes: their reduced camera system is small and dense, where
    // a dense Cholesky beats the sparse one's symbolic overhead.
    options.linear_solver_type = poses.size() <= 40 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    options.max_num_iterations = max_iterations;
    options.num_threads = 1;  // deterministic
    options.minimizer_progress_to_stdout = false;
    options.logging_type = ceres::SILENT;
    ceres::Solver::Summary s;
    if (obs > 0) ceres::Solve(options, &problem, &s);
    summary.observations = obs;
    if (summary.initial_cost == 0) summary.initial_cost = s.initial_cost;
    summary.final_cost = s.final_cost;
    if (!used_stereo) delete ls;  // the problem owns only the losses it was given
    if (!used_mono) delete lm;
  };
  solve(iterations);
  for (int k : free_set) map->keyframes[k].T_cam_world = FromParams(poses[k]);
  for (int p : point_set) map->points[p].p_world = Eigen::Vector3d(pts[p][0], pts[p][1], pts[p][2]);

  if (remove_outliers) {
    std::vector<std::pair<int, int>> bad;
    for (int p : point_set) {
      for (auto& [k, f] : map->points[p].observations) {
        bool stereo = false;
        const double chi2 = ObservationChi2(cam, map->keyframes[k], f, map->points[p].p_world, pyramid, &stereo);
        if (chi2 > (stereo ? kChi2Stereo : kChi2Mono)) bad.emplace_back(p, k);
      }
    }
    for (auto& [p, k] : bad) map->EraseObservation(p, k);
    summary.outliers_removed = static_cast<int>(bad.size());
    if (!bad.empty()) {
      std::set<int> live;
      for (int p : point_set)
        if (!map->points[p].bad) live.insert(p);
      point_set = live;
      solve(std::max(1, iterations / 2));
      for (int k : free_set) map->keyframes[k].T_cam_world = FromParams(poses[k]);
      for (int p : point_set) map->points[p].p_world = Eigen::Vector3d(pts[p][0], pts[p][1], pts[p][2]);
    }
  }
  summary.keyframes = static_cast<int>(free_set.size());
  summary.fixed_keyframes = static_cast<int>(fixed_set.size());
  summary.points = static_cast<int>(point_set.size());
  return summary;
}

void OptimizePoseGraph(std::vector<Eigen::Isometry3d>* T_world_kf, const std::vector<PoseGraphEdge>& edges,
                       const std::vector<int>& fixed, int iterations) {
  std::vector<std::array<double, 6>> params(T_world_kf->size());
  for (size_t i = 0; i < params.size(); ++i) params[i] = ToParams((*T_world_kf)[i]);
  ceres::Problem problem;
  for (const auto& e : edges) {
    RelativePoseResidual r;
    r.q_a_b = Eigen::Quaterniond(e.T_a_b.linear()).normalized();
    r.t_a_b = e.T_a_b.translation();
    r.weight_rotation = 100.0 * std::sqrt(e.weight);    // ~0.01 rad
    r.weight_translation = 10.0 * std::sqrt(e.weight);  // ~0.1 m
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 6, 6>(new RelativePoseResidual(r));
    problem.AddResidualBlock(cost, nullptr, params[e.a].data(), params[e.b].data());
  }
  for (int f : fixed)
    if (problem.HasParameterBlock(params[f].data())) problem.SetParameterBlockConstant(params[f].data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary s;
  ceres::Solve(options, &problem, &s);
  for (size_t i = 0; i < params.size(); ++i)
    if (problem.HasParameterBlock(params[i].data())) (*T_world_kf)[i] = FromParams(params[i]);
}

}  // namespace rs
