#include "stages/slam/global_refinement.h"

#include <array>
#include <algorithm>
#include <cmath>

#include <ceres/ceres.h>

#include "stages/slam/pose_optimizer.h"

namespace rs {
namespace {

// (angle-axis, centre) of T_world_cam: a camera turns about its own centre, so the slow bending
// mode of a long strip (each camera tilted a little and shifted along) is nearly linear in these
// parameters; in (angle-axis, t) of T_cam_world a tilt moves t by the lever arm to the world origin
// (hundreds of metres), and Gauss-Newton then needed ~100 iterations to follow it.
std::array<double, 6> PoseParams(const Eigen::Isometry3d& T_cam_world) {
  const Eigen::Isometry3d T = T_cam_world.inverse();
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(T.linear()));
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  return {w.x(), w.y(), w.z(), T.translation().x(), T.translation().y(), T.translation().z()};
}

Eigen::Isometry3d PoseFromParams(const std::array<double, 6>& p) {
  const Eigen::Vector3d w(p[0], p[1], p[2]);
  const double angle = w.norm();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (angle > 1e-15) T.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  T.translation() = Eigen::Vector3d(p[3], p[4], p[5]);
  return T.inverse();
}

class Reprojection : public ceres::SizedCostFunction<3, 6, 3> {
 public:
  Reprojection(const ReprojectionResidual& r, double disparity_sigma_px) : r_(r), sigma_d_(disparity_sigma_px) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    EvaluateCentreReprojection(r_, sigma_d_, parameters[0], parameters[1], residuals,
                               jacobians ? jacobians[0] : nullptr, jacobians ? jacobians[1] : nullptr);
    return true;
  }

 private:
  ReprojectionResidual r_;
  double sigma_d_;
};

// A map point merged into another (fusion, loop closing) lives on in the one it was merged into.
int LivePoint(const SlamMap& map, int p) {
  for (int hops = 0; p >= 0 && map.points[p].bad && hops < 64; ++hops) p = map.points[p].replaced_by;
  return p >= 0 && !map.points[p].bad ? p : -1;
}

// Stops the solver after the current iteration once the flag is set (the flag may be null).
class CancelCallback : public ceres::IterationCallback {
 public:
  explicit CancelCallback(const std::atomic<bool>* flag) : flag_(flag) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return flag_ != nullptr && flag_->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* flag_;
};

// One residual of the problem: a keyframe's (kf >= 0) or a frame's observation of a point.
struct Obs {
  int kf = -1, frame = -1, index = 0;  // keyframe id + feature, or frame + observation index
  int point = -1;
  ReprojectionResidual r;
};

}  // namespace

void EvaluateCentreReprojection(const ReprojectionResidual& r, double disparity_sigma_px, const double* pose,
                                const double* point, double* residual, double* J_pose, double* J_point) {
  const Eigen::Map<const Eigen::Vector3d> w(pose), c(pose + 3), x(point);
  Eigen::Matrix3d Rt, Jl;  // R(w)^T = R(-w) and the left Jacobian of R at -w
  AngleAxisWithLeftJacobian(-w, &Rt, &Jl);
  const Eigen::Vector3d pc = Rt * (x - c);
  const double iz = 1.0 / pc.z(), s = r.sqrt_info;
  const bool stereo = r.u_right >= 0, uvd = stereo && disparity_sigma_px > 0;
  const double sd = uvd ? 1.0 / disparity_sigma_px : 0.0;  // disparity whitening, level-independent
  residual[0] = (r.fx * pc.x() * iz + r.cx - r.u) * s;
  residual[1] = (r.fy * pc.y() * iz + r.cy - r.v) * s;
  if (uvd)
    residual[2] = (r.fx * r.baseline_m * iz - (r.u - r.u_right)) * sd;
  else
    residual[2] = stereo ? (r.fx * (pc.x() - r.baseline_m) * iz + r.cx - r.u_right) * s : 0.0;
  if (!J_pose && !J_point) return;
  Eigen::Matrix3d D;  // d(residual)/d(pc)
  D.row(0) << r.fx * iz * s, 0, -r.fx * pc.x() * iz * iz * s;
  D.row(1) << 0, r.fy * iz * s, -r.fy * pc.y() * iz * iz * s;
  if (uvd)
    D.row(2) << 0, 0, -r.fx * r.baseline_m * iz * iz * sd;
  else if (stereo)
    D.row(2) << r.fx * iz * s, 0, -r.fx * (pc.x() - r.baseline_m) * iz * iz * s;
  else
    D.row(2).setZero();
  const Eigen::Matrix3d DRt = D * Rt;
  if (J_pose) {
    // d(R(-w) v)/dw = [R(-w) v]_x Jl(-w), v = x - c; d pc / dc = -R^T.
    Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> J(J_pose);
    J.leftCols<3>() = D * Skew(pc) * Jl;
    J.rightCols<3>() = -DRt;
  }
  if (J_point) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(J_point);
    J = DRt;
  }
}

BundleAdjustSummary GlobalBundleAdjustWithFrames(SlamMap* map, std::vector<RefinedFrame>* frames,
                                                 const RectifiedStereo& cam, const ScalePyramid& pyramid,
                                                 int iterations, const std::vector<int>& fixed_kfs,
                                                 double disparity_sigma_px, int min_frame_observations,
                                                 const std::atomic<bool>* cancel) {
  auto cancelled = [cancel] { return cancel != nullptr && cancel->load(); };
  CancelCallback stop_on_cancel(cancel);
  BundleAdjustSummary summary;
  const int nk = static_cast<int>(map->keyframes.size()), nf = static_cast<int>(frames->size());
  auto residual = [&](float u, float v, float u_right, int octave) {
    return ReprojectionResidual{
        u, v, u_right, cam.f_px, cam.f_px, cam.cx_px, cam.cy_px, cam.baseline_m, 1.0 / pyramid.scale[octave]};
  };
  // Frame observations resolved to live points; frames with too few stay where tracking put them.
  for (RefinedFrame& f : *frames) {
    int live = 0;
    for (FrameObservation& o : f.observations) {
      o.point = LivePoint(*map, o.point);
      live += o.point >= 0;
    }
    f.refined = live >= min_frame_observations;
  }
  std::vector<std::array<double, 6>> kf_pose(nk), frame_pose(nf);
  std::vector<std::array<double, 3>> pts(map->points.size());
  std::vector<char> fixed(nk, 0);
  for (int k : fixed_kfs)
    if (k >= 0 && k < nk) fixed[k] = 1;
  for (int k = 0; k < nk; ++k) kf_pose[k] = PoseParams(map->keyframes[k].T_cam_world);
  for (int i = 0; i < nf; ++i) frame_pose[i] = PoseParams((*frames)[i].T_cam_world);
  for (const MapPoint& p : map->points) pts[p.id] = {p.p_world.x(), p.p_world.y(), p.p_world.z()};

  // Every residual, in a fixed order (keyframes' by point id, then frames' by frame) for determinism.
  auto collect = [&] {
    std::vector<Obs> obs;
    for (const MapPoint& p : map->points) {
      if (p.bad) continue;
      for (auto& [k, feat] : p.observations) {
        if (map->keyframes[k].bad) continue;
        const Keyframe& kf = map->keyframes[k];
        const cv::KeyPoint& kp = kf.features.keypoints[feat];
        obs.push_back({k, -1, feat, p.id, residual(kp.pt.x, kp.pt.y, kf.features.u_right[feat], kp.octave)});
      }
    }
    for (int i = 0; i < nf; ++i) {
      const RefinedFrame& f = (*frames)[i];
      if (!f.refined) continue;
      for (size_t j = 0; j < f.observations.size(); ++j) {
        const FrameObservation& o = f.observations[j];
        if (o.point < 0 || map->points[o.point].bad) continue;
        obs.push_back({-1, i, static_cast<int>(j), o.point, residual(o.u, o.v, o.u_right, o.octave)});
      }
    }
    return obs;
  };
  const double sigma_d = disparity_sigma_px;
  auto pose_of = [&](const Obs& o) { return o.kf >= 0 ? kf_pose[o.kf].data() : frame_pose[o.frame].data(); };

  auto solve = [&](const std::vector<Obs>& obs, int max_iterations) {
    ceres::Problem problem;  // owns the two shared loss functions once they are used
    ceres::LossFunction* loss_stereo = new ceres::HuberLoss(std::sqrt(kChi2Stereo));
    ceres::LossFunction* loss_mono = new ceres::HuberLoss(std::sqrt(kChi2Mono));
    bool used_stereo = false, used_mono = false;
    for (const Obs& o : obs) {
      const bool stereo = o.r.u_right >= 0;
      (stereo ? used_stereo : used_mono) = true;
      problem.AddResidualBlock(new Reprojection(o.r, sigma_d), stereo ? loss_stereo : loss_mono, pose_of(o),
                               pts[o.point].data());
    }
    for (int k = 0; k < nk; ++k)
      if (fixed[k] && problem.HasParameterBlock(kf_pose[k].data()))
        problem.SetParameterBlockConstant(kf_pose[k].data());
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_SCHUR;
    options.max_num_iterations = max_iterations;
    options.num_threads = 1;  // deterministic
    options.logging_type = ceres::SILENT;
    if (cancel != nullptr) options.callbacks.push_back(&stop_on_cancel);
    ceres::Solver::Summary s;
    if (!obs.empty()) ceres::Solve(options, &problem, &s);
    if (!used_stereo) delete loss_stereo;
    if (!used_mono) delete loss_mono;
    if (summary.initial_cost == 0) summary.initial_cost = s.initial_cost;
    summary.final_cost = s.final_cost;
    summary.observations = static_cast<int>(obs.size());
  };

  std::vector<Obs> obs = collect();
  solve(obs, iterations);
  if (cancelled()) return summary;
  // Chi-square outliers out (at the same thresholds as tracking and the local BA), then once more.
  int removed = 0;
  for (const Obs& o : obs) {
    double r[3];
    EvaluateCentreReprojection(o.r, sigma_d, pose_of(o), pts[o.point].data(), r, nullptr, nullptr);
    const double chi2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    if (chi2 <= (o.r.u_right >= 0 ? kChi2Stereo : kChi2Mono)) continue;
    ++removed;
    if (o.kf >= 0)
      map->EraseObservation(o.point, o.kf);
    else
      (*frames)[o.frame].observations[o.index].point = -1;
  }
  summary.outliers_removed = removed;
  if (removed > 0) {
    obs = collect();
    solve(obs, std::max(1, iterations / 2));
  }

  for (int k = 0; k < nk; ++k)
    if (!fixed[k] && !map->keyframes[k].bad) map->keyframes[k].T_cam_world = PoseFromParams(kf_pose[k]);
  for (MapPoint& p : map->points)
    if (!p.bad) p.p_world = Eigen::Vector3d(pts[p.id][0], pts[p.id][1], pts[p.id][2]);
  for (int i = 0; i < nf; ++i)
    if ((*frames)[i].refined) (*frames)[i].T_cam_world = PoseFromParams(frame_pose[i]);
  for (int k = 0; k < nk; ++k) {
    if (map->keyframes[k].bad) continue;
    if (fixed[k])
      ++summary.fixed_keyframes;
    else
      ++summary.keyframes;
  }
  for (const MapPoint& p : map->points) summary.points += !p.bad;
  return summary;
}

}  // namespace rs
