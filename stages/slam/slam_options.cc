#include "stages/slam/slam_options.h"

#include <cmath>

#include <fmt/format.h>

#include "survey/options.h"

namespace rs {
namespace {
void Require(bool ok, const char* name, double value, const char* rule) {
  if (!ok) throw OptionError(fmt::format("slam.{} = {} violates {}", name, value, rule));
}
}  // namespace

const char* ToString(SlamRegime regime) {
  switch (regime) {
    case SlamRegime::kAuto: return "auto";
    case SlamRegime::kForward: return "forward";
    case SlamRegime::kNadir: return "nadir";
  }
  return "?";
}

void SlamOptions::Check() const {
  Require(features >= 100, "features", features, "features >= 100");
  Require(pyramid_levels >= 1 && pyramid_levels <= 12, "pyramid_levels", pyramid_levels, "1 <= pyramid_levels <= 12");
  Require(scale_factor > 1.0 && scale_factor <= 2.0, "scale_factor", scale_factor, "1 < scale_factor <= 2");
  Require(fast_threshold >= 1 && fast_threshold <= 100, "fast_threshold", fast_threshold, "1 <= fast_threshold <= 100");
  Require(grid_cell_px >= 8, "grid_cell_px", grid_cell_px, "grid_cell_px >= 8");
  Require(close_depth_baselines > 1, "close_depth_baselines", close_depth_baselines, "close_depth_baselines > 1");
  Require(min_close_points >= 0, "min_close_points", min_close_points, "min_close_points >= 0");
  Require(std::abs(disparity_offset_px) <= 5, "disparity_offset_px", disparity_offset_px, "|disparity_offset_px| <= 5");
  Require(stereo_max_hamming > 0 && stereo_max_hamming <= 256, "stereo_max_hamming", stereo_max_hamming,
          "0 < stereo_max_hamming <= 256");
  Require(match_max_hamming > 0 && match_max_hamming <= 256, "match_max_hamming", match_max_hamming,
          "0 < match_max_hamming <= 256");
  Require(match_ratio > 0 && match_ratio <= 1, "match_ratio", match_ratio, "0 < match_ratio <= 1");
  Require(search_radius_px > 0, "search_radius_px", search_radius_px, "search_radius_px > 0");
  Require(min_tracked_inliers >= 6, "min_tracked_inliers", min_tracked_inliers, "min_tracked_inliers >= 6");
  Require(keyframe_max_gap >= 1, "keyframe_max_gap", keyframe_max_gap, "keyframe_max_gap >= 1");
  Require(keyframe_tracked_ratio > 0 && keyframe_tracked_ratio < 1, "keyframe_tracked_ratio", keyframe_tracked_ratio,
          "0 < keyframe_tracked_ratio < 1");
  Require(local_ba_keyframes >= 1, "local_ba_keyframes", local_ba_keyframes, "local_ba_keyframes >= 1");
  Require(local_ba_iterations >= 1, "local_ba_iterations", local_ba_iterations, "local_ba_iterations >= 1");
  Require(local_map_keyframes >= 1, "local_map_keyframes", local_map_keyframes, "local_map_keyframes >= 1");
  Require(triangulation_neighbours >= 0, "triangulation_neighbours", triangulation_neighbours,
          "triangulation_neighbours >= 0");
  Require(vocabulary_branching >= 2, "vocabulary_branching", vocabulary_branching, "vocabulary_branching >= 2");
  Require(vocabulary_depth >= 1 && vocabulary_depth <= 6, "vocabulary_depth", vocabulary_depth,
          "1 <= vocabulary_depth <= 6");
  Require(loop_min_gap_keyframes >= 1, "loop_min_gap_keyframes", loop_min_gap_keyframes, "loop_min_gap_keyframes >= 1");
  Require(loop_min_inliers >= 10, "loop_min_inliers", loop_min_inliers, "loop_min_inliers >= 10");
  Require(loop_prior_radius_m > 0, "loop_prior_radius_m", loop_prior_radius_m, "loop_prior_radius_m > 0");
  Require(loop_prior_gate_m > 0, "loop_prior_gate_m", loop_prior_gate_m, "loop_prior_gate_m > 0");
  Require(global_ba_iterations >= 0, "global_ba_iterations", global_ba_iterations, "global_ba_iterations >= 0");
  Require(global_ba_disparity_sigma_px >= 0, "global_ba_disparity_sigma_px", global_ba_disparity_sigma_px,
          "global_ba_disparity_sigma_px >= 0");
}

}  // namespace rs
