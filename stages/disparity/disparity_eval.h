#pragma once
// Disparity accuracy metrics, ground-truth pair loaders (Middlebury) and a synthetic
// road pair with exact planar + pothole disparity, for tests and benchmarks.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace rs {

/// Error statistics over an evaluation region. Fractions in [0, 1].
/// Plain fields count invalid estimates as bad (a matcher cannot win by abstaining);
/// *_est fields are over valid estimates only.
struct DisparityMetrics {
  int64_t evaluated = 0;   ///< pixels with truth inside the region
  double density = 0;      ///< valid estimates / evaluated
  double bad1 = 0, bad2 = 0, bad3 = 0;  ///< |d - gt| > 1, 2, 3 px or invalid
  double d1 = 0;           ///< KITTI D1: |d - gt| > 3 px and > 5 % of gt, or invalid
  double bad1_est = 0, bad2_est = 0, bad3_est = 0, d1_est = 0;  ///< same over valid estimates
  double epe = 0;          ///< mean |d - gt| over valid estimates, px
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

/// A rectified grey pair with left-view truth.
struct StereoPairWithTruth {
  std::string name;
  cv::Mat left, right;  ///< CV_8UC1
  cv::Mat gt;           ///< CV_32F disparity of the left view, 0 = unknown
  cv::Mat nonocc;       ///< CV_8U non-occluded truth pixels
  cv::Mat road;         ///< CV_8U evaluation mask (synthetic: undamaged road); may be empty
  cv::Mat pothole;      ///< CV_8U pothole pixels (simulated surveys); may be empty
  int min_disparity = 0, num_disparities = 64;  ///< search range matching the scene
  double focal_px = 0;  ///< rectified focal length where known (DisparityParams::camera_focal_px), else 0
};

/// The four Middlebury pairs under root (…/middlebury): Cloth3, Reindeer, Wood2 (half size,
/// gt = value / 2, range 128) and cone (quarter size, value / 4, range 64).
/// Throws rs::InputError naming the file when one is missing or undecodable.
std::vector<StereoPairWithTruth> LoadMiddlebury(const std::string& root);

/// Synthetic road: a textured plane with roll, seen with disparity d = c0 + cu u + cv v,
/// plus a bowl-shaped pothole (smaller disparity). Exact truth everywhere.
struct SyntheticRoadOptions {
  int width = 1280, height = 720;
  /// Road plane disparity, px: a drone camera pitched forward sees ~47 px at the top right,
  /// ~103 px at the bottom left (plain SGM then needs [0, 112)).
  double c0 = 60, cu = -0.01, cv = 0.06;
  double pothole_u = 700, pothole_v = 520, pothole_radius_px = 90, pothole_depth_px = 5;  ///< depth: disparity drop at centre
  double noise_sigma = 2.0;  ///< grey-level sensor noise added to both views
  unsigned seed = 7;
};
StereoPairWithTruth MakeSyntheticRoadPair(const SyntheticRoadOptions& options);

/// Pools metrics as if all pixels were one image: plain fields weighted by evaluated pixels,
/// *_est fields and EPE by valid estimates.
DisparityMetrics PoolMetrics(const std::vector<DisparityMetrics>& parts);

}  // namespace rs
