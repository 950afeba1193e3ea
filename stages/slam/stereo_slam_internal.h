#pragma once
// Internals of StereoSlam shared by its source files: the per-frame tracking state, the frame records
// and StereoSlam::Impl, whose members are defined by job in stereo_slam.cc (entry points, Track orchestration,
// Finish), stereo_slam_tracking.cc (motion model, reference keyframe, local map), stereo_slam_mapping.cc
// (keyframe decision and insertion, local mapping) and stereo_slam_loss.cc (tracking loss, relocalisation).
// Not a public header: include it only from those files.

#include <chrono>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "stages/slam/global_refinement.h"
#include "stages/slam/pose_optimizer.h"
#include "stages/slam/slam_map.h"
#include "stages/slam/slam_options.h"
#include "stages/slam/slam_regime.h"
#include "stages/slam/stereo_features.h"
#include "stages/slam/stereo_slam.h"

namespace rs {

namespace stereo_slam_internal {

using Clock = std::chrono::steady_clock;
inline double Seconds(Clock::time_point a) { return std::chrono::duration<double>(Clock::now() - a).count(); }

// The frame being tracked (and, after Track, the previous frame).
struct TrackFrame {
  int index = -1;
  int64_t t_ns = 0;
  StereoFeatures f;
  std::vector<int> mp;                   // map point per feature, -1 none
  std::vector<Eigen::Vector3d> p_world;  // 3-D point per matched feature (map point or temporary stereo point)
  std::vector<char> has;                 // p_world valid
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  std::optional<PosePrior> prior;
  double close_depth_m = 0;  // stereo points nearer than this are "close" (CloseDepthLimit)
  // Inliers of the last pose optimisation, map points and the previous frame's temporary stereo
  // points together (OptimizeAndClean returns the map points' alone).
  int all_inliers = 0;
  void Reset(size_t n) {
    mp.assign(n, -1);
    p_world.assign(n, Eigen::Vector3d::Zero());
    has.assign(n, 0);
  }
};

struct FrameRecord {
  int64_t t_ns = 0;
  int ref_kf = -1;
  Eigen::Isometry3d T_cam_ref = Eigen::Isometry3d::Identity();
  FrameStatus status = FrameStatus::kTracked;
  int segment = 0;
  std::optional<Eigen::Vector3d> p_prior;      // the frame's GNSS position (prior world), if any
  std::vector<FrameObservation> observations;  // a tracked non-key frame's map-point matches (final global BA)
};

}  // namespace stereo_slam_internal

struct StereoSlam::Impl {
  using TrackFrame = stereo_slam_internal::TrackFrame;
  using FrameRecord = stereo_slam_internal::FrameRecord;

  SlamOptions opt;
  RectifiedStereo cam;
  ScalePyramid pyr;
  SlamMap map;
  double close_depth_m = 0;  // close_depth_baselines x baseline (a frame's own limit: CloseDepthLimit)
  std::vector<FrameRecord> records;
  TrackFrame last;
  bool has_last = false;
  Eigen::Isometry3d velocity = Eigen::Isometry3d::Identity();
  bool has_velocity = false;
  int ref_kf = -1;
  int last_kf_frame = -1;
  int segment = 0;
  std::vector<int> point_mark;                     // last frame index a point was put in the local map
  std::vector<std::pair<int, int>> recent_points;  // (point, keyframe that created it)
  SlamStatistics stats;
  RegimeChoice regime;          // slam_regime.h: chosen by the first frame, or by the motion of the next ones
  bool regime_started = false;  // the first frame has been seen
  bool finished = false;

  // Tracking (stereo_slam_tracking.cc).
  double CloseDepthLimit(const StereoFeatures& f) const;
  int SearchOne(const TrackFrame& cur, const uint8_t* desc, double u, double v, double ur_pred, double radius,
                int min_level, int max_level, bool ratio_test, int max_hamming) const;
  std::vector<PoseObservation> Observations(const TrackFrame& cur, std::vector<int>* index) const;
  int OptimizeAndClean(TrackFrame* cur);
  void UpdateLastFrame();
  int MatchFromLast(TrackFrame* cur, double radius_factor);
  bool TrackWithMotionModel(TrackFrame* cur);
  bool RelocaliseAgainst(TrackFrame* cur, int kf_id);
  bool TrackReferenceKeyframe(TrackFrame* cur);
  std::vector<int> LocalKeyframes(const TrackFrame& cur);
  int TrackLocalMap(TrackFrame* cur, double th);

  // Tracking loss and relocalisation (stereo_slam_loss.cc).
  Eigen::Vector3d FrameCenter(const FrameRecord& r) const;
  std::optional<Eigen::Isometry3d> PriorToSlam(double sigma_m) const;
  double PlaceLostFrame(TrackFrame* cur) const;
  bool Relocalise(TrackFrame* cur);

  // Keyframes and local mapping (stereo_slam_mapping.cc).
  bool NeedKeyframe(const TrackFrame& cur, int inliers) const;
  int CreateKeyframe(TrackFrame* cur, bool new_segment);
  int CreateNewMapPoints(int kf);
  void CullRecentPoints(int kf);
  void FuseInto(int target, const std::vector<int>& pts);
  void LocalMapping(int kf);

  // Disparity self-calibration (stereo_slam_calibration.cc).
  void ApplyDisparitySelfCalibration();

  // Non-key frames re-solved against the final map (stereo_slam_frames.cc).
  void RefineFramesOnFinalMap();

  // Orchestration and Finish (stereo_slam.cc).
  bool ChooseRegimeFrom(const StereoFeatures& first);
  void DecideRegimeAfter(const TrackFrame& cur, FrameStatus status);
  bool ApplyRegime();
  void EstimateDisparityOffsetOfMap();
  FrameResult Track(int64_t t_ns, const cv::Mat& left, const cv::Mat& right, const std::optional<PosePrior>& prior);
  FrameResult Track(int64_t t_ns, StereoFeatures features, const std::optional<PosePrior>& prior);
  SlamResult Finish();
  // The global BA of `start` with the frames' records (copied: a cancelled run leaves them as they were).
  struct GlobalBaRun {
    SlamMap map;
    std::vector<RefinedFrame> frames;
    std::vector<size_t> record_of;  // frames[j] is records[record_of[j]]
  };
  GlobalBaRun RunGlobalBa(SlamMap start, const std::atomic<bool>* cancel) const;

  // Shared by tracking and mapping.
  Eigen::Vector3d Backproject(const StereoFeatures& f, int i) const {
    const double z = f.depth_m[i];
    return {(f.keypoints[i].pt.x - cam.cx_px) * z / cam.f_px, (f.keypoints[i].pt.y - cam.cy_px) * z / cam.f_px, z};
  }
};

}  // namespace rs
