#pragma once
// The road's own level under a relief image whose road is not flat at large scale (ruts, sags,
// a crown the transformation did not remove): a background mesh in the manner of astronomical
// source extraction. Per cell a clipped median of the relief (damage, a minority of a cell, is
// clipped away), cells a depression fills taken from their neighbours by a 3×3 median of the
// mesh, the mesh interpolated bilinearly. The road shape broader than about two cells is
// followed; depressions up to about two cells across are not.

#include "stages/damage/segment/segmentation.h"

#include <opencv2/core.hpp>

#include <optional>

namespace rs {

/// Per-pixel road level (CV_32F, the relief's units) of `relief` on a mesh of `cell_px` cells.
/// `exclude` (optional CV_8U, non-zero = known damage) is left out of the cells' medians; a cell
/// with fewer than a quarter of its pixels valid and not excluded takes its neighbours' level.
/// Clipping: values beyond `clip_sigma` × `sigma` (the road's noise) of the cell's median are
/// dropped and the median retaken until nothing changes (at most 8 rounds). Throws
/// std::invalid_argument on bad sizes or a non-positive cell or σ.
cv::Mat LocalReliefLevel(const ReliefImage& relief, int cell_px, double sigma, double clip_sigma = 3.0,
                         const cv::Mat& exclude = cv::Mat());

}  // namespace rs

namespace rs {

/// SegmentDepressions on the relief less its local road level (LocalReliefLevel with cell
/// options.level_cell_px; 0 = one level for the image, SegmentDepressions alone): once on the
/// level of every pixel, then again on the level without the depressions found (grown by half
/// a cell), so a large pothole does not pull the road down around itself. `scale` (optional)
/// fixes the road level and σ of the first pass. The result's scale is that of the relief
/// relative to the local level.
DepressionSegmentation SegmentOnLocalLevel(const ReliefImage& relief, const SegmentOptions& options,
                                           std::optional<ReliefScale> scale = std::nullopt);

}  // namespace rs
