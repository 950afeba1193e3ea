#pragma once
// Self-calibration of a constant stereo disparity offset (a residual rectification error: the
// right image's principal point off by a fraction of a pixel) from the SLAM's own keyframes.
//
// A point seen with stereo in keyframes i and j has depths z = bf / (d + o) in both, d the measured
// disparity and o the unknown offset, and z_j = a z_i + tz with a = (R_ji ray_i).z (ray_i = K^-1 (u, v, 1))
// and tz the z component of t_ji. The rotation comes from the SLAM; tz is left free per keyframe pair,
// so the SLAM's own (offset-biased) translation scale does not enter. An offset makes the apparent
// depth change grow with depth, (z_i - z_j)' = tz (1 + o (z_i + z_j) / bf): o is observable wherever
// the camera moves along its optical axis past points at different depths (KITTI: a forward camera),
// and not from a nadir camera moving sideways over flat ground (then the estimate is rejected).
// Used as a diagnostic (StereoSlam reports it, slam_bench prints it): estimates over shorter windows
// scatter beyond their standard error (unmodelled per-frame errors), so it is not applied to the depths.

#include <vector>

#include "stages/slam/slam_map.h"

namespace rs {

/// One point seen with stereo by the keyframes of pair `pair`.
struct DisparityPairSample {
  int pair = 0;             ///< index of the keyframe pair (its own free tz)
  double d_i = 0, d_j = 0;  ///< measured disparities in the two keyframes, px (> 0)
  double a = 1;             ///< (R_ji ray_i).z
};

/// Result of EstimateDisparityOffset.
struct DisparityOffsetEstimate {
  bool valid = false;    ///< enough samples and sigma_px <= the limit
  double offset_px = 0;  ///< to add to every measured disparity
  double sigma_px = 0;   ///< its standard error (robust residual scale x sqrt of the normal-matrix inverse)
  int samples = 0;       ///< samples kept (inliers of the robust fit)
  int pairs = 0;         ///< keyframe pairs with enough samples
};

/// Robust (Huber-IRLS) Gauss-Newton fit of the offset and one tz per pair to the samples: residual
/// d_j + o - bf / (a bf / (d_i + o) + tz), weighted by the propagated disparity noise of both keyframes.
/// valid when at least `min_samples` samples over >= 3 pairs remain and sigma_px <= max_sigma_px.
DisparityOffsetEstimate EstimateDisparityOffset(const std::vector<DisparityPairSample>& samples, int num_pairs,
                                                double bf, int min_samples = 300, double max_sigma_px = 0.03);

/// Samples from the map: every live point seen with stereo by two of `keyframes` (consecutive ones
/// of its observations, sorted by id), one pair index per keyframe pair; *num_pairs receives the count.
std::vector<DisparityPairSample> CollectDisparitySamples(const SlamMap& map, const RectifiedStereo& camera,
                                                         const std::vector<int>& keyframes, int* num_pairs);

/// EstimateDisparityOffset over every good keyframe of the map, the samples from CollectDisparitySamples.
DisparityOffsetEstimate EstimateMapDisparityOffset(const SlamMap& map, const RectifiedStereo& camera);

/// A stereo match whose right position u_right leaves a disparity of 0.05 px or less, or falls off the
/// image, is no match (as MatchStereo drops it).
bool KeepsStereoMatch(double u, double u_right);

/// Adds offset_px to every stereo match's disparity (u_right moves by -offset_px, the depth follows);
/// matches that KeepsStereoMatch rejects afterwards lose their stereo (u_right and depth -1).
void AddDisparityOffset(StereoFeatures* features, const RectifiedStereo& camera, double offset_px);

}  // namespace rs
