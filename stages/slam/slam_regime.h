#pragma once
// The geometry regime of a survey, chosen from the first frames: a forward-looking rig (car: the camera
// moves along its optical axis and often sees the road near and the horizon far) or a nadir one (drone:
// the ground at about one depth, the camera moving sideways across it). They need different mapping: a
// forward view needs keyframe-to-keyframe triangulation (far points for rotation, multi-view points that
// make the map rigid enough for the disparity self-calibration) and more features; on a nadir view that
// triangulation from small-parallax keyframes bends the map. Algorithm and figures: docs/stages/slam.md
// ("Regime").

#include <string>

#include <Eigen/Core>

#include "stages/slam/slam_options.h"
#include "stages/slam/stereo_features.h"

namespace rs {

/// What was chosen and why (SlamStatistics, the stage manifest).
struct RegimeChoice {
  SlamRegime regime = SlamRegime::kNadir;  ///< kForward or kNadir, never kAuto
  bool decided = false;                    ///< false: waiting for the camera to move (DecideRegimeFromMotion)
  bool automatic = false;                  ///< chosen from the frames (options.regime == kAuto)
  int stereo_points = 0;                   ///< first frame's features with a stereo depth
  double depth_p10_m = 0, depth_p50_m = 0, depth_p90_m = 0;  ///< their 10th / 50th / 90th depth percentile
  double depth_spread = 0;                                   ///< depth_p90_m / depth_p10_m (0: too few points)
  double forward_share = 0;  ///< |t_z| / |t| of the camera's motion in the first frame's camera (0: not used)
  /// "forward: first frame's stereo depths span 11.9-42.3 m (x3.56 >= x2.5)".
  std::string reason;
};

/// A view whose stereo depths span at least this ratio (90th / 10th percentile) is deep (forward-looking).
/// Flat ground seen by a camera tilted theta from nadir with a half field of view alpha spans
/// cos(theta - alpha) / cos(theta + alpha): 1.0 at nadir, 1.5 at 20 degrees, 2.4 at 35 degrees (alpha 30);
/// a forward camera over a road sees it from a few metres to the horizon.
inline constexpr double kForwardDepthSpread = 2.5;
/// Fewer stereo points than this in the first frame: the depths are not judged.
inline constexpr int kRegimeMinStereoPoints = 50;
/// A shallow view is forward when the camera moves mostly along its optical axis: |t_z| / |t| at least
/// this (a forward car ~1, a nadir drone ~0; the disparity self-calibration uses the same rule).
inline constexpr double kForwardMotionShare = 0.5;
/// The motion is judged once the camera has moved this share of the first frame's median depth (less is
/// dominated by tracking noise) ...
inline constexpr double kRegimeMinMotionShareOfDepth = 0.05;
/// ... or, if it has not by this frame (a static start), the options as given (nadir) hold.
inline constexpr int kRegimeLastFrame = 10;

/// At the first frame: kForward / kNadir as given; kAuto: forward when the stereo depths are deep, else
/// undecided (decided = false) until the camera moves.
RegimeChoice ChooseRegimeFromDepths(const SlamOptions& options, const StereoFeatures& first_frame);

/// At a later tracked frame (frame_index >= 1) of an undecided choice: t = the camera centre in the first
/// frame's camera coordinates. Decides when it has moved enough or at kRegimeLastFrame; returns decided.
bool DecideRegimeFromMotion(RegimeChoice* choice, const Eigen::Vector3d& t, int frame_index);

/// The options a regime runs with: kNadir returns them as given; kForward sets features to at least 2000,
/// triangulation_neighbours 5 (when 0), local_ba_iterations at most 5, local_ba_fixed_size and
/// keyframe_max_gap at most 5 (docs/stages/slam.md, "Regime"). regime stays as given.
SlamOptions OptionsForRegime(const SlamOptions& options, SlamRegime regime);

}  // namespace rs
