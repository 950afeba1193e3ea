#pragma once
// Offline stereo visual SLAM (ORB-SLAM2 class): ORB front end with stereo depths, constant-velocity
// tracking against the previous frame and the local map, keyframes with synchronous local mapping
// (point culling, fusion, local BA), relocalisation or a new map segment on tracking loss, and in
// Finish() loop detection (bag of words built from the survey's own descriptors + prior proximity),
// geometric verification, pose-graph optimisation and a global BA. Single-threaded apart from the
// left/right feature extraction, so the same input always gives the same trajectory.
// Algorithm and figures: docs/stages/slam.md.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "formats/stereo_calibration.h"
#include "formats/trajectory/trajectory.h"
#include "stages/slam/slam_map.h"
#include "stages/slam/slam_options.h"

namespace rs {

/// How the pose of a frame was obtained.
enum class FrameStatus {
  kTracked,      ///< tracked against the previous frame and the local map
  kRelocalised,  ///< motion-model tracking failed; pose found by matching keyframes (PnP RANSAC)
  kPriorOnly,  ///< tracking and relocalisation failed: pose predicted (motion model, seeded by the GNSS prior), new map
               ///< segment
};
/// "tracked", "relocalised", "prior-only".
const char* ToString(FrameStatus status);

/// Per-frame outcome of StereoSlam::Track.
struct FrameResult {
  int index = 0;  ///< 0-based Track call
  int64_t t_ns = 0;
  FrameStatus status = FrameStatus::kTracked;
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();  ///< at tracking time (before loop closing)
  int features = 0;                                               ///< ORB features in the left image
  int stereo_features = 0;                                        ///< of which with a stereo depth
  int inliers = 0;                                                ///< map points matched after local-map tracking
  bool keyframe = false;                                          ///< a keyframe was made from this frame
  int segment = 0;                                                ///< map segment the frame belongs to
  /// prior-only frames: weight of the flight log's position in the pose (0: motion model alone, 1: GNSS alone)
  double gnss_weight = 0;
};

/// A closed loop.
struct LoopClosure {
  int keyframe = -1;       ///< the newer keyframe
  int loop_keyframe = -1;  ///< the older keyframe it re-observes
  int inliers = 0;         ///< inliers of the verification that accepted it (guided map search or two-view)
  bool by_prior = false;   ///< candidate came from position (SLAM track or GNSS prior proximity), else appearance
};

/// Counters and timings of a run.
struct SlamStatistics {
  /// The geometry regime the run used (never kAuto) and why: "forward: first frame's stereo depths span ..."
  /// (slam_regime.h); chosen at the first frame, or by the motion of the next ones.
  SlamRegime regime = SlamRegime::kNadir;
  std::string regime_reason;
  int frames = 0, tracked = 0, relocalised = 0, prior_only = 0;
  int gnss_positioned = 0;  ///< prior-only frames placed mostly (weight >= 0.5) by the flight log
  /// tracked frames with fewer than min_tracked_inliers map points, held by >= 3x that many stereo
  /// inliers of the previous frame's points (each made a keyframe)
  int held_by_odometry = 0;
  int keyframes = 0, map_points = 0, segments = 1;
  int loop_candidates = 0, loops_rejected = 0, loops_closed = 0;
  int vocabulary_words = 0;
  /// Disparity offset implied by the keyframes' own motion (disparity_calibration.h), its standard error (px)
  /// and the samples used; estimated in Finish before loop closing, over the whole map
  double disparity_offset_px = 0, disparity_offset_sigma_px = 0;
  int disparity_offset_samples = 0;
  /// What the self-calibration (options.disparity_self_calibration) added to every disparity before the
  /// global BA (on top of options.disparity_offset_px), px; 0 when the estimate was not certain enough
  double disparity_offset_applied_px = 0;
  double track_s = 0;          ///< wall time in Track (front end + tracking + local mapping)
  double local_mapping_s = 0;  ///< of which local mapping (culling, fusion, local BA)
  double finish_s = 0;         ///< wall time of Finish (loop closing + global BA)
  /// "regime nadir, 95 frames (95 tracked, 0 relocalised, 0 prior-only), 31 keyframes, 9120 points, 0 loops".
  std::string BriefReport() const;
};

/// Everything a run produced.
struct SlamResult {
  Trajectory frames;                ///< camera-to-world per frame (after loop closing and global BA)
  Trajectory keyframes;             ///< camera-to-world per keyframe
  std::vector<FrameStatus> status;  ///< per frame
  std::vector<int> frame_segment;   ///< per frame
  SlamMap map;                      ///< keyframes, points, observations (enough for a COLMAP export)
  std::vector<LoopClosure> loops;
  SlamStatistics stats;
};

/// The SLAM system. Feed frames in time order with Track, then call Finish once.
class StereoSlam {
 public:
  /// rectified: a rectified calibration (StereoRectifier::rectified() or a rectified layout's).
  /// Throws std::invalid_argument when it is not rectified or has no baseline, OptionError for bad options.
  StereoSlam(const StereoCalibration& rectified, const SlamOptions& options);
  ~StereoSlam();
  StereoSlam(const StereoSlam&) = delete;
  StereoSlam& operator=(const StereoSlam&) = delete;

  /// Tracks one rectified 8-bit grey pair (sizes equal to the calibration's). Never throws on a
  /// tracking failure: the frame is then relocalised or predicted (prior-only). Throws
  /// std::invalid_argument for images of the wrong size/type or times that do not increase.
  FrameResult Track(int64_t t_ns, const cv::Mat& left, const cv::Mat& right, const std::optional<PosePrior>& prior);

  /// Tracks a pair whose features were computed beforehand (ExtractStereoFeatures / MatchStereo with
  /// camera(), options() and pyramid()), e.g. on other threads while the previous frame was tracked
  /// (SlamPipeline). Same result as the image overload. Throws std::invalid_argument when times do not increase.
  FrameResult Track(int64_t t_ns, StereoFeatures features, const std::optional<PosePrior>& prior);

  const RectifiedStereo& camera() const;  ///< the rectified camera the features must be computed for
  /// The options in effect: those given to the constructor, once the regime is decided with the regime's
  /// (OptionsForRegime; the features of later frames must be computed with these).
  const SlamOptions& options() const;
  /// The regime (slam_regime.h) is decided: options() no longer changes. Decided at the first frame when
  /// its stereo depths are deep or the regime is given, else by the camera's motion within 10 frames.
  bool RegimeDecided() const;
  const ScalePyramid& pyramid() const;  ///< scale pyramid of the options

  /// Loop closing, global BA; returns trajectories, map and statistics. Call once.
  SlamResult Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rs
