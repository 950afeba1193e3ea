#pragma once
// Cracks: thin dark ridges of the left image inside the road region, found by a classical
// detector (multi-scale Hessian ridge or morphological black-hat) or the learned model
// (crack_net.h), measured along their skeleton.

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"

#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// Result of DetectCracks.
struct CrackDetection {
  cv::Mat labels;                         ///< CV_16U, ids 1..n (0 = none)
  std::vector<DamageInstance> instances;  ///< type crack; metric fields NaN without pixel sizes
  double response_threshold = 0;          ///< black-hat level used (grey levels); learned: probability
  CrackOptions::Detector detector = CrackOptions::Detector::kRidge;  ///< the one used (never kAuto)
};

/// kAuto runs the learned model on images no larger than this a side: patches like those it was
/// trained on (close-up crops of 120–240 px). On whole road frames in pixel units (fan2019, 1710 ×
/// 1028) it marked 15 % of the image as crack against the ridge's 1 % (docs/results/damage.md).
inline constexpr int kAutoLearnedMaxSidePx = 384;

/// The detector DetectCracks runs for `options` on an image of `size` with (`calibrated`) or
/// without pixel sizes: kAuto = kLearned without pixel sizes on images up to
/// kAutoLearnedMaxSidePx a side when the model file exists, else kRidge (which runs the metric
/// black-hat with pixel sizes).
CrackOptions::Detector ResolveCrackDetector(const CrackOptions& options, bool calibrated, cv::Size size);

/// "learned", "ridge", "black-hat" (kRidge with pixel sizes: the metric black-hat runs), "auto".
const char* CrackDetectorName(CrackOptions::Detector detector, bool calibrated);

/// Detects cracks in `image` (8-bit grey or BGR). `road_mask` (CV_8U, non-zero = road;
/// empty = whole image) limits the search; `exclude` (CV_8U, non-zero, may be empty)
/// removes pixels already explained (potholes, obstacles). `pixel_size_m` (CV_32F,
/// metres per pixel on the road; empty = unknown) turns lengths and widths into metres;
/// without it the minimum length is options.min_length_px and metric fields stay NaN.
/// Width along the skeleton = 2·(distance to the crack edge) − 1 px; length = 8-connected
/// skeleton path length (diagonal steps √2). Confidence = mean black-hat contrast above the
/// median / (2·k·σ), clamped to [0, 1]; learned: the mean probability.
/// The response level is local (options.level_cell_px): median + k·σ per cell of the searched
/// road, interpolated; learned: the probability at the model's threshold (or
/// options.learned_threshold). Both detectors' candidates go through the same measurement and
/// filters (closing, length, elongation, width). `response` (optional): CrackResponse(image, options, pixel_size_m),
/// computed beforehand (DetectDamage runs it alongside the segmentation); empty = computed here.
CrackDetection DetectCracks(const cv::Mat& image, const cv::Mat& road_mask, const cv::Mat& exclude,
                            const cv::Mat& pixel_size_m, const CrackOptions& options,
                            const cv::Mat& response = cv::Mat());

/// The evidence (CV_8U) of `image` (8-bit grey or BGR) that DetectCracks thresholds: the
/// learned probability × 255 when ResolveCrackDetector says kLearned (throws CrackModelError
/// naming the model file when it is missing or unusable), else the black-hat response.
/// With `pixel_size_m` (CV_32F, metres per pixel on the road, NaN off-road) and
/// options.element_width_m > 0: one element per image row spanning element_width_m of road
/// (rows without road: 0); else the pixel scales min_scale_px..max_scale_px (step 4).
cv::Mat CrackResponse(const cv::Mat& image, const CrackOptions& options, const cv::Mat& pixel_size_m = cv::Mat());

}  // namespace rs
