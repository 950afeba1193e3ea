#pragma once
// The disparity stage's second image (DisparityResult::disparity_sharp: its 9x9 refinement window
// alone, before the 21x21 smooth window is taken) as depth below the road. The smooth window
// spreads a sloping pothole wall's depth 5-8 px onto the road and makes the floor beside the wall
// shallower; the small window keeps the wall where it is, at more per-pixel noise. A sum over the
// whole depression averages that noise away, so the volume is summed on it; detection, the
// outline and the max depth (a percentile, which per-pixel noise would bias deep) stay on the
// smooth image. docs/stages/damage.md, Method 3.

#include "stages/damage/damage_types.h"
#include "stages/damage/road/road_surface.h"

#include <opencv2/core.hpp>

namespace rs {

/// Depth below the road (mm, CV_32F) of `sharp_disparity_px` at the pixels of `labels` (CV_16U,
/// non-zero) where `disparity_px` (the main image as the damage stage uses it: beyond the analysed
/// range already invalid) is valid, NaN elsewhere: the quadratic model `surface` minus the local
/// correction `correction_mm` (RoadRelief::correction_mm; empty = none), i.e. what
/// RoadRelief::depth_below_mm is before the relief's smoothing. Only the labels' bounding boxes
/// are evaluated. Throws std::invalid_argument when the images differ in size or type.
cv::Mat SharpDepthBelowMm(const cv::Mat& sharp_disparity_px, const cv::Mat& disparity_px, const cv::Mat& labels,
                          const RectifiedStereo& geometry, const RoadSurface& surface, const cv::Mat& correction_mm);

}  // namespace rs
