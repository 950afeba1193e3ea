#pragma once
// Cracks: thin dark ridges of the left image inside the road region, found by a
// multi-scale morphological black-hat, measured along their skeleton.

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"

#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// Result of DetectCracks.
struct CrackDetection {
  cv::Mat labels;                         ///< CV_16U, ids 1..n (0 = none)
  std::vector<DamageInstance> instances;  ///< type crack; metric fields NaN without pixel sizes
  double response_threshold = 0;          ///< black-hat level used (grey levels)
};

/// Detects cracks in `image` (8-bit grey or BGR). `road_mask` (CV_8U, non-zero = road;
/// empty = whole image) limits the search; `exclude` (CV_8U, non-zero, may be empty)
/// removes pixels already explained (potholes, obstacles). `pixel_size_m` (CV_32F,
/// metres per pixel on the road; empty = unknown) turns lengths and widths into metres;
/// without it the minimum length is options.min_length_px and metric fields stay NaN.
/// Width along the skeleton = 2·(distance to the crack edge) − 1 px; length = 8-connected
/// skeleton path length (diagonal steps √2). Confidence = mean black-hat contrast above the
/// median / (2·k·σ), clamped to [0, 1].
/// The response level is local (options.level_cell_px): median + k·σ per cell of the searched
/// road, interpolated. `response` (optional): CrackResponse(image, options, pixel_size_m),
/// computed beforehand (DetectDamage runs it alongside the segmentation); empty = computed here.
CrackDetection DetectCracks(const cv::Mat& image, const cv::Mat& road_mask, const cv::Mat& exclude,
                            const cv::Mat& pixel_size_m, const CrackOptions& options,
                            const cv::Mat& response = cv::Mat());

/// The black-hat response (CV_8U) of `image` (8-bit grey or BGR) that DetectCracks thresholds.
/// With `pixel_size_m` (CV_32F, metres per pixel on the road, NaN off-road) and
/// options.element_width_m > 0: one element per image row spanning element_width_m of road
/// (rows without road: 0); else the pixel scales min_scale_px..max_scale_px (step 4).
cv::Mat CrackResponse(const cv::Mat& image, const CrackOptions& options, const cv::Mat& pixel_size_m = cv::Mat());

}  // namespace rs
