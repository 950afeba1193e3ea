#pragma once
// Coarse per-cell grids of the road model: filling empty cells (road relief correction, local
// noise) from their neighbours, so that damage, obstacles and holes in the disparity take the
// surrounding road's value instead of a made-up one; labelling the smooth regions of a grid
// (the road fit's samples, split at kerbs and obstacles).

#include <opencv2/core.hpp>

namespace rs {

/// `grid` is CV_32F with NaN marking empty cells. Each pass gives every empty cell with at least
/// one filled 8-neighbour the mean of those neighbours (ring by ring inwards, from the pass's
/// start values); passes repeat until no cell is empty. A grid without any filled cell is left
/// as it is (all NaN): the caller decides the fallback value.
void FillEmptyCellsFromNeighbours(cv::Mat* grid);

/// Labels the regions of a CV_32F grid (NaN = empty) in which 4-neighbours are joined when their
/// values differ by less than `max_step` and no two cells in line across the link do (a step whose
/// face holds a cell; the cells right beside a step may so form a thin region): a smooth surface is one region, a step
/// (a kerb up to the pavement) or an empty band (an obstacle) separates two. Returns CV_32S labels, 0 on empty cells,
/// regions numbered from 1; `*count` (optional) = number of regions.
cv::Mat LabelSmoothRegions(const cv::Mat& grid, float max_step, int* count = nullptr);

}  // namespace rs
