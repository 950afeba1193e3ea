#pragma once
// Local noise of a relief image. Stereo errors are not stationary: where the disparity
// stage's road model leaves the road off its integer residual (camber, the outer thirds of a
// nadir frame), SGM's pixel locking adds ±0.2 px ripples, and paint edges add more, while the
// rest of the frame is quiet. One global σ either misses shallow damage in the quiet part or
// reports the ripples as damage; a per-region σ tests every candidate against the noise
// where it lies.

#include <opencv2/core.hpp>

#include <limits>

namespace rs {

/// Road samples farther than this many frame σ above the road are structure (an obstacle's
/// smoothed fringe, the model bent beside it), not matching noise: the `max_ratio` the damage
/// stage passes to its noise maps.
inline constexpr double kStructureSigmaRatio = 40.0;

/// Per-pixel robust noise σ of `value` (CV_32F) over `valid` (CV_8U), in the units of `value`:
/// per cell of `cell_px`, the median of (x − level) over the valid x above `level` (and below
/// level + max_ratio·floor_sigma: farther above is structure, e.g. an obstacle's fringe), / 0.6745
/// (damage only fills the lower tail, so the upper half measures the road's own spread);
/// cells with fewer than 20 such samples, or fewer than 35 % of their valid samples above the
/// level (mostly damage), take their neighbours' value; 3×3 smoothed over the
/// cells, bilinearly interpolated, and never below `floor_sigma`.
/// Throws std::invalid_argument on bad types or sizes, cell_px < 4, floor_sigma ≤ 0 or max_ratio ≤ 0.
/// `quantile` (in (0, 1)) other than 0.5: that quantile of those samples, unscaled, instead of the median
/// / 0.6745 (e.g. 0.999: how far the road's upward spikes reach, LocalReliefSpikes).
cv::Mat LocalReliefNoise(const cv::Mat& value, const cv::Mat& valid, double level, int cell_px, double floor_sigma,
                         double max_ratio = std::numeric_limits<double>::infinity(), double quantile = 0.5);

/// LocalReliefNoise of the samples below `level`: the same as LocalReliefNoise(−value, valid,
/// −level, cell_px, floor_sigma, max_ratio), without the negated copy of the image.
cv::Mat LocalReliefNoiseBelow(const cv::Mat& value, const cv::Mat& valid, double level, int cell_px, double floor_sigma,
                              double max_ratio = std::numeric_limits<double>::infinity());

/// How far the road's matching errors reach: the `quantile` (e.g. 0.999) of the upward
/// deviations (x − level) per cell, as LocalReliefNoise otherwise. SGM's wrong winners (a
/// wrong disparity minimum over a ~10 px patch) err either way; upward they cannot be damage,
/// so their reach above the road bounds what downward ones fake as depressions there.
inline cv::Mat LocalReliefSpikes(const cv::Mat& value, const cv::Mat& valid, double level, int cell_px,
                                 double floor_sigma, double max_ratio, double quantile) {
  return LocalReliefNoise(value, valid, level, cell_px, floor_sigma, max_ratio, quantile);
}

}  // namespace rs
