#pragma once
// Filling the empty cells of a coarse per-cell grid (road relief correction, local noise) from
// their neighbours, so that damage, obstacles and holes in the disparity take the surrounding
// road's value instead of a made-up one.

#include <opencv2/core.hpp>

namespace rs {

/// `grid` is CV_32F with NaN marking empty cells. Each pass gives every empty cell with at least
/// one filled 8-neighbour the mean of those neighbours (ring by ring inwards, from the pass's
/// start values); passes repeat until no cell is empty. A grid without any filled cell is left
/// as it is (all NaN): the caller decides the fallback value.
void FillEmptyCellsFromNeighbours(cv::Mat* grid);

}  // namespace rs
