#pragma once
// A depression's depth against the road's noise at the depression's own scale. The pothole
// rule's noise (LocalReliefNoise, TwoSidedReliefNoise, LocalReliefSpikes) is measured per pixel
// of the relief, whose box filter is a few pixels wide: SGM's wrong winners (~10 px patches)
// and the per-pixel matching noise set it. A depression many times wider than those patches
// is not one of them: averaged over a window as wide as its core, the road's short-range noise
// falls while the depression keeps its depth. Long-range errors (pixel-locking ripples that
// follow the road's residual over hundreds of pixels) do not fall, so they keep guarding.

#include <opencv2/core.hpp>

namespace rs {

/// The road's noise and a depression's depth, both box-averaged over `window_px` × `window_px`.
struct ScaleNoise {
  int window_px = 0;
  double depth_mm = 0;  ///< the depression's deepest window mean (over its own pixels)
  double sigma_mm =
      0;  ///< min(σ above, 2·σ below the road) of the window means around it (two-sided, as TwoSidedReliefNoise)
  double spike_mm = 0;  ///< the `spike_quantile` of the window means above the road around it (as LocalReliefSpikes)
  int samples = 0;      ///< road window means the spreads were taken from (above the road + below it)
};

/// ScaleNoise of instance `id` of `labels` (CV_16U) on `depth_below_mm` (CV_32F, mm below the
/// road, road at 0, NaN = no measurement), over the pixels of `road` (CV_8U, non-zero = road:
/// valid, not obstacle). Road window means are taken within `margin_px` of the instance's
/// bounding box `box`, off the instance grown by half a window (its own walls, smoothed, are
/// not the road's noise; other depressions stay in, as in TwoSidedReliefNoise's leave-one-out),
/// every second pixel; a window mean needs half its window measured. The spreads are the
/// median deviation / 0.6745 on each side of 0 (σ never below `floor_sigma_mm`); NaN where
/// fewer than 50 means lie on a side.
/// Throws std::invalid_argument on bad types or sizes, window_px < 1 or an empty box.
ScaleNoise MeasureScaleNoise(const cv::Mat& depth_below_mm, const cv::Mat& road, const cv::Mat& labels, int id,
                             const cv::Rect& box, int window_px, int margin_px, double spike_quantile,
                             double floor_sigma_mm);

}  // namespace rs
