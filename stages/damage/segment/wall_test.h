#pragma once
// A pothole is a hole with a wall: along its outline the surface drops steeply, far more than
// the road's own roughness tilts it. A broad shallow sag or rut the road level did not follow
// crosses the segmentation threshold on a slope no steeper than the road's roughness.

#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// Slope magnitude of a relief and the road's slope noise.
struct ReliefSlope {
  cv::Mat magnitude;  ///< CV_32F, the relief's units per px; NaN where no valid pixel is near
  double noise = 0;   ///< σ of one slope component on the road (outside every instance)
};

/// Slopes are central differences of `value` (CV_32F) after a Gaussian of σ `smooth_px` over
/// `valid` (CV_8U) pixels only; the noise is the median slope magnitude outside `labels`
/// (CV_16U, 0 = road) over 1.177, the Rayleigh median of a 2-D Gaussian gradient of σ 1 per
/// component.
ReliefSlope MeasureReliefSlope(const cv::Mat& value, const cv::Mat& valid, const cv::Mat& labels,
                               double smooth_px = 2.0);

/// Steepness of each instance's wall: the median slope magnitude over the band of `band_px`
/// pixels just inside its outline, in units of the road's slope noise (the road's own slopes have
/// a median of 1.18 σ). `labels`: CV_16U ids 1..count, those `slope` was measured with.
/// Returns count + 1 entries (entry 0 unused; NaN where an instance's band holds no valid pixel).
std::vector<double> WallSteepness(const ReliefSlope& slope, const cv::Mat& labels, int count, int band_px = 3);

/// Removes instances whose wall steepness is below `min_steepness` (NaN kept) and renumbers the
/// rest 1..n in order. Returns the number removed.
int DropInstancesWithoutWall(cv::Mat* labels, int* count, const std::vector<double>& steepness, double min_steepness);

}  // namespace rs
