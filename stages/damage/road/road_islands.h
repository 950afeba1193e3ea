#pragma once
// Road that is not connected to the road: islands of the road mask (valid disparity, not above
// the road) enclosed by obstacle and unmatched pixels. On an untextured obstacle (a parked car's
// body) the matcher returns disparities tens of pixels off; most of them land above the road (obstacle) or far beyond
// it (out of range), but scattered patches land within the road band and, measured against the road model, read as
// 70–950 mm deep "depressions" on the car. A real depression is part of the road surface: the
// road around it continues over metres.

#include <opencv2/core.hpp>

namespace rs {

/// CV_8U mask (255) of the pixels of `road` (CV_8U, non-zero = road) lying in a connected road
/// region (8-neighbourhood) whose area on the road, the sum of `pixel_area_m2` (CV_32F, m² per
/// pixel; NaN or negative counts 0) over the region, is below `min_area_m2`.
/// Computed on 2×2 blocks (a block is road when all four pixels are): a quarter of the work, and a
/// one-pixel bridge does not join an island to the road. Pixels of partial blocks are never in
/// the result (they count as road). `min_area_m2` ≤ 0: an empty (all-zero) mask.
/// Throws std::invalid_argument on masks of other types or sizes.
cv::Mat RoadIslandMask(const cv::Mat& road, const cv::Mat& pixel_area_m2, double min_area_m2);

/// Removes the islands from the instance `labels` (CV_16U, 0 = none): an instance with at least as
/// many pixels on `islands` as on the rest of `road` is removed whole (its unmatched pixels, which
/// the segmentation joins to a depression they border, go with it); any other loses its island
/// pixels. Returns the number of instances removed whole.
/// Throws std::invalid_argument on images of other types or sizes.
int RemoveIslandLabels(cv::Mat& labels, const cv::Mat& islands, const cv::Mat& road);

}  // namespace rs
