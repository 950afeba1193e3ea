#include "eval/trajectory/kitti00_ba.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "eval/trajectory/slam_datasets.h"
#include "eval/trajectory/trajectory_metrics.h"
#include "formats/input_error.h"
#include "formats/trajectory/kitti_poses.h"
#include "stages/slam/disparity_calibration.h"
#include "stages/slam/global_refinement.h"
#include "stages/slam/slam_map.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

// Reads `count` numbers from `in`; throws InputError at path:line when the line has fewer.
std::vector<double> Numbers(std::istringstream& in, int count, const std::string& path, int64_t line) {
  std::vector<double> v(static_cast<size_t>(count));
  for (double& x : v)
    if (!(in >> x) || !std::isfinite(x))
      throw InputError(InputLocation::Line(path, line), fmt::format("expected {} numbers", count));
  return v;
}

Eigen::Isometry3d PoseOf(const std::vector<double>& m, size_t first, const std::string& path, int64_t line) {
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T(r, c) = m[first + static_cast<size_t>(4 * r + c)];
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() <= 0)
    throw InputError(InputLocation::Line(path, line), "pose is not a rotation and translation");
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  out.translation() = T.topRightCorner<3, 1>();
  return out;
}

std::ifstream Open(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw InputError(InputLocation::File(p.string()), "cannot open");
  return in;
}

// Calls row(numbers, line) for every non-blank line of `path`, each of `count` numbers.
template <typename Row>
void ForEachRow(const fs::path& path, int count, Row row) {
  std::ifstream in = Open(path);
  std::string line;
  for (int64_t n = 1; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    row(Numbers(ss, count, path.string(), n), n);
  }
}

// The problem as a SlamMap: one keyframe per pose, one level-0 feature per observation, one point per landmark.
SlamMap MapOf(const StereoVoProblem& pb) {
  SlamMap map;
  std::vector<std::vector<const StereoVoObservation*>> by_pose(pb.T_world_cam.size());
  for (const StereoVoObservation& o : pb.observations) by_pose[static_cast<size_t>(o.pose)].push_back(&o);
  for (size_t k = 0; k < pb.T_world_cam.size(); ++k) {
    Keyframe kf;
    kf.id = static_cast<int>(k);
    kf.frame_index = kf.id;
    kf.T_cam_world = pb.T_world_cam[k].inverse();
    for (const StereoVoObservation* o : by_pose[k]) {
      kf.features.keypoints.emplace_back(static_cast<float>(o->u_left), static_cast<float>(o->v), 31.f, -1.f, 0.f, 0);
      kf.features.u_right.push_back(static_cast<float>(o->u_right));
      const double d = o->u_left - o->u_right;
      kf.features.depth_m.push_back(d > 0 ? static_cast<float>(pb.camera.bf() / d) : -1.f);
    }
    kf.features.descriptors = cv::Mat::zeros(static_cast<int>(by_pose[k].size()), 32, CV_8U);
    kf.points.assign(by_pose[k].size(), -1);
    map.keyframes.push_back(std::move(kf));
  }
  std::map<int, int> point_of;  // landmark -> map point
  for (size_t k = 0; k < by_pose.size(); ++k)
    for (size_t i = 0; i < by_pose[k].size(); ++i) {
      const StereoVoObservation& o = *by_pose[k][i];
      const auto it = point_of.find(o.landmark);
      if (it == point_of.end())
        point_of[o.landmark] = map.AddPoint(pb.T_world_cam[k] * o.p_cam, static_cast<int>(k), static_cast<int>(i));
      else
        map.AddObservation(it->second, static_cast<int>(k), static_cast<int>(i));
    }
  return map;
}

// The poses of a map's keyframes (camera-to-world), keyframe i = pose i.
std::vector<Eigen::Isometry3d> PosesOf(const SlamMap& map) {
  std::vector<Eigen::Isometry3d> out;
  for (const Keyframe& kf : map.keyframes) out.push_back(kf.T_cam_world.inverse());
  return out;
}

Trajectory TrajectoryOf(const std::vector<Eigen::Isometry3d>& poses, size_t count, const std::string& source) {
  Trajectory t;
  t.source = source;
  t.has_times = false;
  for (size_t i = 0; i < count; ++i) t.poses.push_back({static_cast<int64_t>(i), poses[i]});
  return t;
}

// ATE (SE(3)) and the last pose's error with the first poses coinciding (both start at the identity).
std::pair<double, double> Score(const std::vector<Eigen::Isometry3d>& est, const std::vector<Eigen::Isometry3d>& gt) {
  const PosePairs pairs =
      AssociateByIndex(TrajectoryOf(est, est.size(), "adjusted poses"), TrajectoryOf(gt, est.size(), "ground truth"));
  const double end = (pairs.est.back().translation() - pairs.gt.back().translation()).norm();
  return {ComputeAte(pairs, TrajectoryAlignment::kSE3).translation_m.rmse, end};
}

// The problem adjusted from its initial poses with offset_px added to every disparity.
struct Adjusted {
  SlamMap map;
  BundleAdjustSummary summary;
  double seconds = 0;
};

Adjusted Adjust(const StereoVoProblem& pb, int iterations, double offset_px) {
  Adjusted a;
  a.map = MapOf(pb);
  if (offset_px != 0)
    for (Keyframe& kf : a.map.keyframes) AddDisparityOffset(&kf.features, pb.camera, offset_px);
  std::vector<RefinedFrame> no_frames;
  const auto t0 = std::chrono::steady_clock::now();
  a.summary = GlobalBundleAdjustWithFrames(&a.map, &no_frames, pb.camera, ScalePyramid(1, 1.2), iterations, {0}, 0);
  a.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return a;
}

}  // namespace

StereoVoProblem ReadGtsamStereoVo(const fs::path& calibration, const fs::path& poses, const fs::path& factors,
                                  int width, int height) {
  StereoVoProblem pb;
  {
    std::ifstream in = Open(calibration);
    std::string line;
    if (!std::getline(in, line)) throw InputError(InputLocation::Line(calibration.string(), 1), "empty file");
    std::istringstream ss(line);
    const std::vector<double> v = Numbers(ss, 6, calibration.string(), 1);
    if (v[0] != v[1] || v[2] != 0)
      throw InputError(InputLocation::Line(calibration.string(), 1), "fx != fy or skew != 0: not a rectified pair");
    pb.camera = {v[0], v[3], v[4], v[5], width, height};
  }
  ForEachRow(poses, 17, [&](const std::vector<double>& v, int64_t n) {
    if (v[0] != static_cast<double>(pb.T_world_cam.size()))
      throw InputError(InputLocation::Line(poses.string(), n),
                       fmt::format("pose id {} out of order (expected {})", v[0], pb.T_world_cam.size()));
    pb.T_world_cam.push_back(PoseOf(v, 1, poses.string(), n));
  });
  ForEachRow(factors, 8, [&](const std::vector<double>& v, int64_t n) {
    StereoVoObservation o;
    o.pose = static_cast<int>(v[0]);
    o.landmark = static_cast<int>(v[1]);
    if (o.pose < 0 || o.pose >= static_cast<int>(pb.T_world_cam.size()))
      throw InputError(InputLocation::Line(factors.string(), n), fmt::format("pose {} is not in the poses", o.pose));
    o.u_left = v[2];
    o.u_right = v[3];
    o.v = v[4];
    o.p_cam = Eigen::Vector3d(v[5], v[6], v[7]);
    pb.observations.push_back(o);
  });
  return pb;
}

StereoVoBaReport AdjustAndScore(const StereoVoProblem& pb, const std::vector<Eigen::Isometry3d>& gt, int iterations) {
  if (gt.size() < pb.T_world_cam.size())
    throw std::invalid_argument(
        fmt::format("AdjustAndScore: {} ground-truth poses for {} poses", gt.size(), pb.T_world_cam.size()));
  StereoVoBaReport r;
  r.poses = static_cast<int>(pb.T_world_cam.size());
  r.observations = static_cast<int>(pb.observations.size());
  for (size_t i = 1; i < pb.T_world_cam.size(); ++i) r.path_m += (gt[i].translation() - gt[i - 1].translation()).norm();
  std::tie(r.ate_before_m, r.end_error_before_m) = Score(pb.T_world_cam, gt);
  const SlamMap initial = MapOf(pb);
  r.landmarks = static_cast<int>(initial.points.size());
  r.reproj_median_before_px = LevelZeroResiduals(initial, pb.camera).median_px;

  const Adjusted plain = Adjust(pb, iterations, 0);
  r.outliers_removed = plain.summary.outliers_removed;
  r.seconds = plain.seconds;
  std::tie(r.ate_after_m, r.end_error_after_m) = Score(PosesOf(plain.map), gt);
  r.reproj_median_after_px = LevelZeroResiduals(plain.map, pb.camera).median_px;

  // As the SLAM's self-calibration: the offset the adjusted map implies, then the adjustment with it.
  const DisparityOffsetEstimate e = EstimateMapDisparityOffset(plain.map, pb.camera);
  r.offset_px = e.offset_px;
  r.offset_sigma_px = e.sigma_px;
  r.offset_samples = e.samples;
  const Adjusted calibrated = Adjust(pb, iterations, r.offset_px);
  std::tie(r.ate_calibrated_m, r.end_error_calibrated_m) = Score(PosesOf(calibrated.map), gt);
  r.reproj_median_calibrated_px = LevelZeroResiduals(calibrated.map, pb.camera).median_px;
  return r;
}

std::string StereoVoBaReport::Summary() const {
  return fmt::format(
      "KITTI 00 frames 0-{} stereo BA (GTSAM's VO measurements): {} poses, {} landmarks, {} observations, "
      "{} outliers removed, {:.2f} s\n"
      "  ATE RMSE (SE3) {:.3f} m -> {:.3f} m over {:.1f} m; last pose {:.3f} m -> {:.3f} m; "
      "reprojection median {:.3f} px -> {:.3f} px\n"
      "  disparity offset implied by the adjusted map {:+.3f} px +- {:.3f} ({} samples); BA with it: ATE {:.3f} m, "
      "last pose {:.3f} m, reprojection median {:.3f} px",
      poses - 1, poses, landmarks, observations, outliers_removed, seconds, ate_before_m, ate_after_m, path_m,
      end_error_before_m, end_error_after_m, reproj_median_before_px, reproj_median_after_px, offset_px,
      offset_sigma_px, offset_samples, ate_calibrated_m, end_error_calibrated_m, reproj_median_calibrated_px);
}

StereoVoBaReport RunKitti00StereoVoBa(const fs::path& data, int iterations) {
  const fs::path g = data / "kitti_euroc_trajectories/gtsam/examples/Data";
  // KITTI odometry 00's grey images are 1241 x 376.
  const StereoVoProblem pb = ReadGtsamStereoVo(g / "VO_calibration00s.txt", g / "VO_camera_poses00s.txt",
                                               g / "VO_stereo_factors00s.txt", 1241, 376);
  const fs::path gt_path = data / "kitti_euroc_trajectories/evo/test/data/KITTI_00_gt.txt";
  std::ifstream in = Open(gt_path);
  return AdjustAndScore(pb, ReadKittiPoses(in, gt_path.string()), iterations);
}

}  // namespace rs
