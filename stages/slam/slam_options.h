#pragma once
// Options of the stereo visual SLAM core (rs_slam_core). Plain struct, in-class defaults,
// one comment per field, Check() stating the violated rule. Documented in docs/stages/slam.md.

namespace rs {

/// Geometry regime (slam_regime.h): which mapping the survey's view needs.
enum class SlamRegime {
  kAuto,     ///< chosen from the first frame's stereo depth range (slam_regime.h)
  kForward,  ///< forward-looking (car): more features, keyframe triangulation (OptionsForRegime)
  kNadir,    ///< nadir (drone): the options as given
};
/// "auto", "forward", "nadir".
const char* ToString(SlamRegime regime);

/// Every tunable of StereoSlam. Defaults suit 10-20 Hz rectified stereo of 0.1-0.6 m baseline.
struct SlamOptions {
  SlamRegime regime = SlamRegime::kAuto;  ///< forward: features, triangulation, local BA, keyframe gap set by
                                          ///< OptionsForRegime; nadir: all as given; auto: chosen by the first frame
  // --- front end
  int features = 1200;                ///< ORB features kept per image after grid spreading
  int pyramid_levels = 8;             ///< scale pyramid levels
  double scale_factor = 1.2;          ///< scale ratio between pyramid levels
  int fast_threshold = 12;            ///< FAST threshold, grey levels (low: grid spreading ranks by Harris score)
  int grid_cell_px = 40;              ///< cell size of the grid that spreads features over the image, px
  double close_depth_baselines = 40;  ///< a stereo point is "close" (reliable depth) below this many baselines
  int min_close_points = 600;   ///< a frame with < 100 close stereo points (a nadir view from altitude): the nearest
                                ///< this many count as close
  int stereo_max_hamming = 75;  ///< largest descriptor distance of a left-right stereo match
  double disparity_offset_px =
      0;  ///< added to every measured disparity: a residual rectification error (right principal point), px
  bool disparity_self_calibration = true;  ///< at the end, add the disparity offset the whole map's motion implies (if
                                           ///< known to 0.03 px) to every stereo measurement before the global BA
  // --- tracking
  int match_max_hamming = 100;   ///< largest descriptor distance of a frame-to-map match
  double match_ratio = 0.8;      ///< best / second-best distance ratio for local-map matches
  double search_radius_px = 7;   ///< search radius when projecting the previous frame's points (x pyramid scale)
  int min_tracked_inliers = 20;  ///< fewer inliers after local-map tracking = tracking lost
  // --- keyframes and local mapping
  int keyframe_max_gap = 10;             ///< insert a keyframe at least every this many frames
  double keyframe_tracked_ratio = 0.75;  ///< keyframe when inliers < ratio * points tracked by the reference keyframe
  int local_ba_keyframes = 8;            ///< keyframes optimised by each local bundle adjustment
  int local_ba_iterations = 8;           ///< Levenberg-Marquardt iterations of each local BA pass
  bool local_ba_fixed_size = false;  ///< local BA by bundle_adjust_solver.h (fixed-size Schur blocks, ~5x less CPU than
                                     ///< Ceres; same minimum, other rounding) instead of Ceres
  int local_map_keyframes = 20;      ///< keyframes whose points form the local map tracked against
  int triangulation_neighbours =
      0;  ///< covisible keyframes matched with each new keyframe to triangulate new points (0: off; 10 = ORB-SLAM2)
  // --- loop closure (run in StereoSlam::Finish)
  bool loop_closure = true;         ///< detect and close loops, then run a global bundle adjustment
  int vocabulary_branching = 16;    ///< branching factor of the bag-of-words vocabulary tree
  int vocabulary_depth = 3;         ///< depth of the vocabulary tree (words = branching^depth at most)
  int loop_min_gap_keyframes = 20;  ///< a loop candidate must be at least this many keyframes older
  int loop_min_inliers = 60;        ///< stereo SE(3) RANSAC inliers needed to accept a loop
  double loop_prior_radius_m = 15;  ///< keyframes whose priors lie within this distance are loop candidates
  double loop_prior_gate_m = 10;    ///< reject a loop whose relative translation disagrees with the priors by more
  int global_ba_iterations = 20;    ///< Ceres iterations of the global bundle adjustment
  bool global_ba_frames =
      false;  ///< the global BA also optimises every tracked frame with its map-point matches (global_refinement.h)
  double global_ba_disparity_sigma_px =
      0;  ///< global BA: stereo disparity sigma, px (0: right-image u at the keypoint's sigma, as the local BA)
  // --- determinism / threads
  unsigned ransac_seed = 1;  ///< seed of every RANSAC: same input and seed give the same result
  bool parallel = true;      ///< extract the next frames' features on two threads (left, right) while one is tracked
                             ///< (SlamPipeline; result unchanged)

  /// Throws rs::OptionError naming the violated rule ("slam.features = 10 violates features >= 100").
  void Check() const;
};

}  // namespace rs
