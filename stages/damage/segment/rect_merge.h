#pragma once
// Merging overlapping regions of interest, so per-region work (relief refinement, segmentation
// seeds) never touches a pixel twice.

#include <vector>

#include <opencv2/core.hpp>

namespace rs {

/// Replaces any two overlapping rectangles by their bounding union until none overlap.
void MergeOverlappingRects(std::vector<cv::Rect>* rects);

}  // namespace rs
