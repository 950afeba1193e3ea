#pragma once
// Evaluation of damage detection against ground truth: pixel metrics of the
// damage mask and instance matching at IoU ≥ 0.5 with measurement errors.

#include "stages/damage/damage_types.h"

#include <opencv2/core.hpp>

#include <limits>

#include <vector>

namespace rs {

/// Pixel-level agreement of a predicted mask with a ground-truth mask.
struct PixelMetrics {
  long long tp = 0, fp = 0, fn = 0, tn = 0;
  double precision = 0, recall = 0, f1 = 0, iou = 0;  ///< 0 when undefined (no positives anywhere)
  /// Accumulates another frame's counts and recomputes the ratios (overall = pooled pixels).
  void Add(const PixelMetrics& other);
  void Finish();
};

/// Compares masks (any single-channel type, non-zero = damage) of equal size;
/// `ignore` (optional CV_8U, non-zero = don't count) excludes pixels.
/// Throws std::invalid_argument on size or channel mismatch.
PixelMetrics ComparePixels(const cv::Mat& predicted, const cv::Mat& truth, const cv::Mat& ignore = cv::Mat());

/// Truth for one ground-truth instance (NaN = unknown, not scored).
struct TruthInstance {
  int id = 0;  ///< label value in the truth label image
  double area_m2 = std::numeric_limits<double>::quiet_NaN();
  double max_depth_m = std::numeric_limits<double>::quiet_NaN();
  double volume_m3 = std::numeric_limits<double>::quiet_NaN();
};

/// One matched pair and its measurement errors (predicted − truth).
struct InstanceMatch {
  int predicted_id = 0, truth_id = 0;
  double iou = 0;
  double area_error_m2 = std::numeric_limits<double>::quiet_NaN();
  double max_depth_error_m = std::numeric_limits<double>::quiet_NaN();
  double volume_error_m3 = std::numeric_limits<double>::quiet_NaN();
};

/// Instance-level result.
struct InstanceEvaluation {
  std::vector<InstanceMatch> matches;
  int predicted = 0, truth = 0;
  int false_positives = 0, false_negatives = 0;
  double precision = 0, recall = 0, f1 = 0;
};

/// Greedy one-to-one matching by descending IoU (pairs below `min_iou` never match) between
/// label images (CV_16U or CV_32S ids, 0 = background). Measurement errors are filled for
/// predicted instances found in `predicted` (by id) and truth found in `truth`.
InstanceEvaluation MatchInstances(const cv::Mat& predicted_labels, const cv::Mat& truth_labels,
                                  const std::vector<DamageInstance>& predicted = {},
                                  const std::vector<TruthInstance>& truth = {}, double min_iou = 0.5);

}  // namespace rs
