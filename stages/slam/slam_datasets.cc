#include "stages/slam/slam_datasets.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <random>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "formats/stereo/image_io.h"
#include "formats/stereo/rectifier.h"
#include "formats/stereo/stereo_source.h"
#include "formats/trajectory/trajectory_file.h"
#include "stages/slam/trajectory_transform.h"

namespace rs {
namespace {

using Clock = std::chrono::steady_clock;
double CpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

double PathLength(const PosePairs& pairs) {
  double len = 0;
  for (size_t i = 1; i < pairs.size(); ++i) len += (pairs.gt[i].translation() - pairs.gt[i - 1].translation()).norm();
  return len;
}

// Level-0 reprojection residuals of every live map point in every keyframe observing it.
void MeasureResiduals(const StereoCalibration& calib, SlamRunReport* rep) {
  const double fx = calib.left.fx, fy = calib.left.fy, cx = calib.left.cx, cy = calib.left.cy, b = calib.BaselineM();
  std::vector<double> uv, ur;
  const SlamMap& m = rep->result.map;
  for (const MapPoint& p : m.points) {
    if (p.bad) continue;
    for (const auto& [k, f] : p.observations) {
      const Keyframe& kf = m.keyframes[k];
      const cv::KeyPoint& kp = kf.features.keypoints[f];
      if (kf.bad || kp.octave != 0) continue;
      const Eigen::Vector3d pc = kf.T_cam_world * p.p_world;
      if (pc.z() <= 0) continue;
      const double u = fx * pc.x() / pc.z() + cx, v = fy * pc.y() / pc.z() + cy;
      uv.push_back(std::hypot(kp.pt.x - u, kp.pt.y - v));
      if (kf.features.u_right[f] >= 0) ur.push_back(std::abs(kf.features.u_right[f] - (u - fx * b / pc.z())));
    }
  }
  auto quantile = [](std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
    std::nth_element(v.begin(), v.begin() + i, v.end());
    return v[i];
  };
  rep->reproj_median_px = quantile(uv, 0.5);
  rep->reproj_p90_px = quantile(uv, 0.9);
  rep->reproj_right_median_px = quantile(ur, 0.5);
}

// Runs SLAM over `source` frames; `rectify` (may be null) maps raw pairs to rectified ones.
SlamRunReport RunSource(const StereoSource& source, const StereoCalibration& rectified, const SlamOptions& options,
                        const StereoRectifier* rectifier, int max_frames,
                        const std::vector<std::optional<PosePrior>>* priors) {
  SlamRunReport rep;
  rep.width = rectified.left.width;
  rep.height = rectified.left.height;
  StereoSlam slam(rectified, options);
  const size_t n = max_frames < 0 ? source.frames().size() : std::min<size_t>(max_frames, source.frames().size());
  for (size_t i = 0; i < n; ++i) {
    const StereoFrame& fr = source.frames()[i];
    auto tl = Clock::now();
    cv::Mat l = LoadGray8(fr.left), r = LoadGray8(fr.right);
    if (rectifier) {
      cv::Mat lr, rr;
      rectifier->Rectify(l, r, &lr, &rr);
      l = lr;
      r = rr;
    }
    rep.load_s += std::chrono::duration<double>(Clock::now() - tl).count();
    const double c0 = CpuSeconds();
    const auto t0 = Clock::now();
    rep.frames.push_back(slam.Track(fr.t_ns, l, r, priors ? (*priors)[i] : std::nullopt));
    rep.wall_s += std::chrono::duration<double>(Clock::now() - t0).count();
    rep.cpu_s += CpuSeconds() - c0;
  }
  const double c0 = CpuSeconds();
  const auto t0 = Clock::now();
  rep.result = slam.Finish();
  rep.wall_s += std::chrono::duration<double>(Clock::now() - t0).count();
  rep.cpu_s += CpuSeconds() - c0;
  MeasureResiduals(rectified, &rep);
  return rep;
}

}  // namespace

std::string SlamRunReport::Summary(const std::string& name) const {
  const int frames = result.stats.frames;
  return fmt::format(
      "{}: {}x{}, {}\n  ATE RMSE (SE3) {:.4f} m ({:.3f} % of {:.1f} m path), max {:.4f} m, rot RMSE {:.3f} deg\n"
      "  wall {:.2f} s = {:.1f} frames/s (local mapping {:.2f} s, finish {:.2f} s), CPU {:.2f} s = {:.1f} frames/CPU-s, "
      "image loading {:.2f} s\n  level-0 reprojection residual median {:.3f} px (p90 {:.3f}), right-u median {:.3f} px",
      name, width, height, result.stats.BriefReport(), ate.translation_m.rmse,
      path_length_m > 0 ? 100 * ate.translation_m.rmse / path_length_m : 0.0, path_length_m, ate.translation_m.max,
      ate.rotation_deg.rmse, wall_s, frames / std::max(1e-9, wall_s), result.stats.local_mapping_s,
      result.stats.finish_s, cpu_s, frames / std::max(1e-9, cpu_s), load_s, reproj_median_px, reproj_p90_px,
      reproj_right_median_px);
}

SlamRunReport RunKittiOdometry(const std::filesystem::path& folder, const SlamOptions& options, int max_frames) {
  const StereoSource source = OpenStereoSource(folder, "kitti-odometry");
  SlamRunReport rep = RunSource(source, *source.calibration(), options, nullptr, max_frames, nullptr);
  Trajectory gt = ReadTrajectory(folder / "poses.txt", TrajectoryFormat::kKitti);
  gt.poses.resize(rep.result.frames.poses.size());
  Trajectory est = rep.result.frames;
  const PosePairs pairs = AssociateByIndex(est, gt);
  rep.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  rep.path_length_m = PathLength(pairs);
  return rep;
}

SlamRunReport RunEuroc(const std::filesystem::path& dataset, const std::filesystem::path& gt_tum,
                       const SlamOptions& options) {
  const StereoSource source = OpenStereoSource(dataset, "euroc");
  const StereoRectifier rectifier = StereoRectifier::Create(*source.calibration());
  SlamRunReport rep = RunSource(source, rectifier.rectified(), options, &rectifier, -1, nullptr);
  // T_body_cam0 from cam0/sensor.yaml, then the rectifying rotation: T_body_rect = T_BS * [R1^T | 0].
  cv::FileStorage fs((dataset / "mav0" / "cam0" / "sensor.yaml").string(), cv::FileStorage::READ);
  std::vector<double> data;
  fs["T_BS"]["data"] >> data;
  if (data.size() != 16) throw std::runtime_error("cam0/sensor.yaml: T_BS.data needs 16 numbers");
  Eigen::Isometry3d T_body_cam = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T_body_cam.linear()(r, c) = data[r * 4 + c];
    T_body_cam.translation()(r) = data[r * 4 + 3];
  }
  Eigen::Isometry3d T_cam_rect = Eigen::Isometry3d::Identity();
  const auto& R1 = rectifier.R_rectleft_left();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) T_cam_rect.linear()(r, c) = R1[c * 3 + r];
  const Trajectory gt = ApplyExtrinsic(ReadTrajectory(gt_tum, TrajectoryFormat::kTum), T_body_cam * T_cam_rect);
  const PosePairs pairs = AssociateByTimestamp(rep.result.frames, gt, 2'000'000);
  rep.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  rep.path_length_m = PathLength(pairs);
  return rep;
}

SlamRunReport RunSimulated(const std::filesystem::path& folder, const SlamOptions& options, bool use_priors,
                           double prior_noise_m) {
  const StereoSource source = OpenStereoSource(folder, "plain");
  const Trajectory gt = ReadTrajectory(folder / "truth" / "trajectory.tum", TrajectoryFormat::kTum);
  std::vector<std::optional<PosePrior>> priors(source.frames().size());
  if (use_priors) {
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0, prior_noise_m);
    for (size_t i = 0; i < priors.size() && i < gt.poses.size(); ++i) {
      PosePrior p;
      p.T_world_cam = gt.poses[i].T_world_frame;
      p.T_world_cam.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      p.has_attitude = false;
      p.sigma_position_m = prior_noise_m;
      priors[i] = p;
    }
  }
  SlamRunReport rep = RunSource(source, *source.calibration(), options, nullptr, -1, &priors);
  const PosePairs pairs = AssociateByTimestamp(rep.result.frames, gt, 1'000'000);
  rep.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  rep.path_length_m = PathLength(pairs);
  return rep;
}

}  // namespace rs
