#pragma once
// Runs StereoSlam over the public test sequences with metric truth (KITTI odometry clip, KITTI raw
// drive, EuRoC micro, a simulator folder) and scores it. Shared by slam_test and slam_bench.

#include <filesystem>
#include <string>

#include "stages/slam/stereo_slam.h"
#include "eval/trajectory/trajectory_metrics.h"

namespace rs {

/// Outcome of one run against truth.
struct SlamRunReport {
  SlamResult result;
  std::vector<FrameResult> frames;  ///< what Track returned per frame
  AteResult ate;                    ///< SE(3)-aligned ATE of the frame trajectory (camera frames)
  double path_length_m = 0;         ///< length of the true camera path
  /// RMSE of the rotation error relative to the first pair, angle((R_gt0^T R_gt)^T (R_est0^T R_est)), deg:
  /// no alignment involved (the aligned rotation RMSE is ill-posed on straight or static paths, where
  /// the roll about the path is unobservable from positions), so a camera/truth frame mix-up shows here.
  double rot_rel_first_rmse_deg = 0;
  std::vector<Eigen::Vector3d>
      rot_rel_first_err;                 ///< per pair: that error as a rotation vector (truth camera frame), deg
  std::vector<double> gt_rel_first_deg;  ///< per pair: the true rotation since the first pair, deg
  double wall_s = 0;                     ///< decoding (ahead, as in the stage), Track and Finish: wall time
  double cpu_s = 0;                      ///< process CPU time over the same span (all threads)
  /// Wall time the same work implies on two free cores (pipelined runs, SlamPipelineTimes::TwoCoreWallSeconds
  /// from per-thread CPU times, plus Finish's CPU); 0 if not pipelined.
  double two_core_wall_s = 0;
  double features_cpu_s = 0, track_cpu_s = 0, finish_cpu_s = 0;  ///< its parts (pipelined runs): thread CPU, s
  double load_s = 0;  ///< of it, the tracking thread waiting for a decoded pair (+ rectification)
  /// Median / 90th percentile of the final map's level-0 reprojection residuals (|(du, dv)| and
  /// |du_right|, px) with the final keyframe poses: how consistent keypoints, depths and poses are.
  double reproj_median_px = 0, reproj_p90_px = 0, reproj_right_median_px = 0;
  int width = 0, height = 0;
  std::string Summary(const std::string& name) const;
};

/// Level-0 reprojection residuals of every live map point in every good keyframe observing it:
/// median and 90th percentile of |(du, dv)| and median |du_right|, px (0 when there are none).
struct MapResiduals {
  double median_px = 0, p90_px = 0, right_median_px = 0;
};
MapResiduals LevelZeroResiduals(const SlamMap& map, const RectifiedStereo& camera);

/// KITTI odometry layout with poses.txt (compared pose i to frame i). max_frames < 0: all.
SlamRunReport RunKittiOdometry(const std::filesystem::path& folder, const SlamOptions& options, int max_frames = -1);
/// EuRoC/ASL mav0 folder: raw pairs rectified via rs_stereo_io; truth = a TUM body trajectory,
/// compared through cam0's T_BS and the rectifying rotation.
SlamRunReport RunEuroc(const std::filesystem::path& dataset, const std::filesystem::path& gt_tum,
                       const SlamOptions& options);
/// KITTI raw drive (rectified colour pairs read as grey) against its OXTS GPS/INS positions (local ENU
/// at the first record), associated by index, positions only: the OXTS unit sits ~1 m from the camera,
/// a constant offset while the car drives straight (SE(3) alignment absorbs it, not a turn).
/// rot_rel_first_* are not computed (the OXTS attitude is of the vehicle).
SlamRunReport RunKittiRaw(const std::filesystem::path& drive, const SlamOptions& options);
/// Plain layout written by the simulator with truth/trajectory.tum (camera poses). use_priors: feed
/// the true positions (+ noise sigma_m, fixed seed) as priors.
SlamRunReport RunSimulated(const std::filesystem::path& folder, const SlamOptions& options, bool use_priors,
                           double prior_noise_m = 1.0);

/// Disparities of the stereo front end against LiDAR depth (KITTI raw drive folder with
/// proj_depth/velodyne/image_02/*.npz, LiDAR depth projected into the left camera).
struct LidarDisparityCheck {
  int samples = 0;                ///< stereo features with a consistent LiDAR depth (5x5 px, spread < 5 %)
  double median_deficit_px = 0;   ///< median of bf / z_lidar - measured disparity, px
  double median_depth_ratio = 1;  ///< median of stereo depth / LiDAR depth
};
/// Runs ExtractStereoFeatures (options as given) over every frame of the drive and compares.
LidarDisparityCheck CheckDisparityAgainstLidar(const std::filesystem::path& drive, const SlamOptions& options);

}  // namespace rs
