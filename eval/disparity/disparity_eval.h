#pragma once
// Disparity accuracy metrics and ground-truth pair loaders (Middlebury).

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "sim/synthetic_road_pair.h"

namespace rs {

/// Error statistics over an evaluation region. Fractions in [0, 1].
/// Plain fields count invalid estimates as bad (a matcher cannot win by abstaining);
/// *_est fields are over valid estimates only.
struct DisparityMetrics {
  int64_t evaluated = 0;                ///< pixels with truth inside the region
  double density = 0;                   ///< valid estimates / evaluated
  double bad1 = 0, bad2 = 0, bad3 = 0;  ///< |d - gt| > 1, 2, 3 px or invalid
  double d1 = 0;                        ///< KITTI D1: |d - gt| > 3 px and > 5 % of gt, or invalid
  double bad1_est = 0, bad2_est = 0, bad3_est = 0, d1_est = 0;  ///< same over valid estimates
  double epe = 0;                                               ///< mean |d - gt| over valid estimates, px
};

/// Metrics over all truth pixels, non-occluded ones, and a caller's mask (e.g. road).
struct DisparityEvaluation {
  DisparityMetrics all, nonocc, masked;
  DisparityMetrics pothole;  ///< over StereoPairWithTruth::pothole (simulated surveys)
};

/// est: CV_32F disparity; est_valid: CV_8U (non-zero valid); gt: CV_32F (0 = unknown);
/// region: CV_8U (non-zero = evaluate) or empty for all truth pixels.
DisparityMetrics EvaluateDisparity(const cv::Mat& est, const cv::Mat& est_valid, const cv::Mat& gt,
                                   const cv::Mat& region = cv::Mat());

/// Non-occluded pixels of the left view: both truths known and left-right consistent
/// (|gt_left(u) - gt_right(round(u - gt_left(u)))| <= tolerance_px). CV_8U 255/0.
cv::Mat NonOccludedMask(const cv::Mat& gt_left, const cv::Mat& gt_right, double tolerance_px = 1.0);

/// The four Middlebury pairs under root (…/middlebury): Cloth3, Reindeer, Wood2 (half size,
/// gt = value / 2, range 128) and cone (quarter size, value / 4, range 64).
/// Throws rs::InputError naming the file when one is missing or undecodable.
std::vector<StereoPairWithTruth> LoadMiddlebury(const std::string& root);

/// Pools metrics as if all pixels were one image: plain fields weighted by evaluated pixels,
/// *_est fields and EPE by valid estimates.
DisparityMetrics PoolMetrics(const std::vector<DisparityMetrics>& parts);

}  // namespace rs
