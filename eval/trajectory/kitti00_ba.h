#pragma once
// The SLAM's global bundle adjustment on real KITTI measurements: GTSAM's stereo visual-odometry
// example data (examples/Data/VO_*00s.txt: KITTI odometry sequence 00, frames 0-76, 52 544 stereo
// observations (u_left, u_right, v) of landmarks, the visual-odometry poses as the initial estimate)
// adjusted with the first pose fixed, and the poses scored against KITTI's ground truth for those
// frames before and after.

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "formats/rectified_stereo.h"

namespace rs {

/// One stereo observation: pose `pose` sees landmark `landmark` at (u_left, v) and (u_right, v);
/// p_cam is the landmark's initial position in that camera (the file's X Y Z).
struct StereoVoObservation {
  int pose = 0, landmark = 0;
  double u_left = 0, u_right = 0, v = 0;
  Eigen::Vector3d p_cam = Eigen::Vector3d::Zero();
};

/// The problem as the files state it.
struct StereoVoProblem {
  RectifiedStereo camera;
  std::vector<Eigen::Isometry3d> T_world_cam;  ///< initial poses by id (camera-to-world)
  std::vector<StereoVoObservation> observations;
};

/// Reads calibration (`fx fy skew cx cy baseline`), poses (`id` + 4x4 row-major camera-to-world, ids
/// 0, 1, 2, ...) and factors (`pose landmark uL uR v X Y Z`). Throws InputError naming the
/// file and line on a malformed or missing entry, a pose id out of order, or fx != fy / skew != 0.
StereoVoProblem ReadGtsamStereoVo(const std::filesystem::path& calibration, const std::filesystem::path& poses,
                                  const std::filesystem::path& factors, int width, int height);

/// Before / after figures.
struct StereoVoBaReport {
  int poses = 0, landmarks = 0, observations = 0, outliers_removed = 0;
  double ate_before_m = 0, ate_after_m = 0;                        ///< ATE RMSE, SE(3)-aligned to the ground truth
  double end_error_before_m = 0, end_error_after_m = 0;            ///< last pose's error, first poses coinciding
  double reproj_median_before_px = 0, reproj_median_after_px = 0;  ///< left-image reprojection error
  /// The disparity offset the adjusted map implies (disparity_calibration.h), and the adjustment redone
  /// with it added to every disparity, as the SLAM's self-calibration does.
  double offset_px = 0, offset_sigma_px = 0;
  int offset_samples = 0;
  double ate_calibrated_m = 0, end_error_calibrated_m = 0, reproj_median_calibrated_px = 0;
  double path_m = 0;   ///< ground-truth path length
  double seconds = 0;  ///< the adjustment's wall time
  std::string Summary() const;
};

/// Adjusts the problem with GlobalBundleAdjustWithFrames (pose 0 fixed, `iterations`) and scores every
/// pose against `gt` (camera-to-world, pose i = frame i, first pose at the identity in both).
StereoVoBaReport AdjustAndScore(const StereoVoProblem& problem, const std::vector<Eigen::Isometry3d>& gt,
                                int iterations);

/// The shared data's KITTI 00 run: `data` is the shared data folder (kitti_euroc_trajectories/ inside).
StereoVoBaReport RunKitti00StereoVoBa(const std::filesystem::path& data, int iterations = 20);

}  // namespace rs
