#pragma once
// Global perspective transformation (GPT, MISSION eqs. 1, 2, 5): shift each target row so the
// road has a small non-negative residual disparity, and map disparities back.
//
// Sign convention: left = reference. A road point at column u of the left image lies at
// u - d in the right image. kappa(v) = min_x road(x, v) - delta; the warped target is
// I_t'(u, v) = I_t(u - kappa(v), v), so a disparity l found on (I_r, I_t') means the true
// disparity d = l + kappa(v). kappa depends on the row only (the minimum runs over x), so the
// warp is a rigid sub-pixel shift of each row.

#include <vector>

#include <opencv2/core/mat.hpp>

#include "stages/disparity/road_model.h"

namespace rs {

/// kappa(v) for v in [0, height): min over x in [0, width) of road(x, v), minus delta_px.
std::vector<double> ComputeGptShift(const RoadModel& road, int width, int height, double delta_px);

/// I_t'(u, v) = I_t(u - kappa[v], v) with linear interpolation; columns that fall outside
/// the target replicate its border (those pixels cannot match and the left-right check drops them).
cv::Mat WarpTarget(const cv::Mat& target_gray8, const std::vector<double>& kappa);

/// Per-pixel variant of the warp: I_t'(u, v) = I_t(u - s(u, v), v) with s = road(u, v) - delta_px,
/// linear interpolation (1/256 weights), borders replicated. The road's residual disparity is then
/// delta everywhere (not only at the row minimum), so on the road the matcher sees one integer
/// disparity (delta integer) and sub-pixel interpolation has no pixel-locking bias there. A
/// disparity l found on (I_r, I_t') means d = l + s(u - l, v).
cv::Mat WarpTargetPerPixel(const cv::Mat& target_gray8, const RoadModel& road, double delta_px);

/// True disparity d = l + kappa(v) on valid pixels, 0 elsewhere (CV_32F).
cv::Mat TrueFromWarpedDisparity(const cv::Mat& warped_disparity, const cv::Mat& valid,
                                const std::vector<double>& kappa);

/// Transformed disparity l' = d - road(u, v) + delta on valid pixels, 0 elsewhere (CV_32F):
/// flat road -> delta, potholes below delta, obstacles above.
cv::Mat TransformedDisparity(const cv::Mat& true_disparity, const cv::Mat& valid, const RoadModel& road,
                             double delta_px);

/// One row v of TransformedDisparity (same arithmetic), for callers that fuse it into their own pass.
void TransformedDisparityRow(const float* true_disparity, const uint8_t* valid, int width, int v, const RoadModel& road,
                             double delta_px, float* out);

}  // namespace rs
