#pragma once
// The geometry regime of a survey, chosen from the calibration and the first frame's stereo depths:
// a forward-looking rig (car: the road near, the horizon far) or a nadir one (drone: the ground at about
// one depth). The two need different mapping: a deep forward view needs keyframe-to-keyframe
// triangulation to use its far points and more features (the near field fills only part of the image);
// on a shallow nadir view that triangulation from small-parallax keyframes bends the map.
// Algorithm and figures: docs/stages/slam.md ("Regime").

#include <string>

#include "stages/slam/slam_options.h"
#include "stages/slam/stereo_features.h"

namespace rs {

/// What was chosen and why (recorded in SlamStatistics and the stage manifest).
struct RegimeChoice {
  SlamRegime regime = SlamRegime::kNadir;   ///< kForward or kNadir, never kAuto
  bool automatic = false;                   ///< chosen from the first frame (options.regime == kAuto)
  int stereo_points = 0;                    ///< first frame's features with a stereo depth
  double depth_p10_m = 0, depth_p90_m = 0;  ///< their 10th / 90th depth percentile
  double depth_spread = 0;                  ///< depth_p90_m / depth_p10_m (0: too few points)
  /// "forward: first frame's stereo depths span 4.1-52.0 m (x12.7 >= x3)".
  std::string reason;
};

/// A view whose stereo depths span at least this ratio (90th / 10th percentile) is deep (forward-looking).
/// Flat ground seen by a camera tilted theta from nadir with a half field of view alpha spans
/// cos(theta - alpha) / cos(theta + alpha): 1.0 at nadir, 1.5 at 20 degrees, 2.4 at 35 degrees (alpha 30);
/// a forward camera over a road sees it from a few metres to the horizon.
inline constexpr double kForwardDepthSpread = 2.5;
/// Fewer stereo points than this in the first frame: too few to judge, the options as given (nadir) hold.
inline constexpr int kRegimeMinStereoPoints = 50;

/// Chooses the regime for options.regime: kForward / kNadir as given, kAuto from the first frame's stereo depths.
RegimeChoice ChooseRegime(const SlamOptions& options, const StereoFeatures& first_frame);

/// The options a regime runs with: kNadir returns them as given; kForward sets features to at least 2000,
/// triangulation_neighbours 5 (when 0), local_ba_iterations 5, local_ba_fixed_size and keyframe_max_gap 5
/// (docs/stages/slam.md, "Regime"). regime stays as given.
SlamOptions OptionsForRegime(const SlamOptions& options, SlamRegime regime);

}  // namespace rs
