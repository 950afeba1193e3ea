#include "stages/damage/noise/relief_noise.h"

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "stages/damage/road/grid_fill.h"
#include "survey/stats/order_statistic.h"
#include "survey/stats/robust_stats.h"

namespace rs {

namespace {

// LocalReliefNoise of `value`, or (kMirrored) of −value with `level` already mirrored: the
// samples below the level, without a negated copy of the frame (the same values).
template <bool kMirrored>
cv::Mat NoiseOf(const cv::Mat& value, const cv::Mat& valid, double level, int cell, double floor_sigma,
                double max_ratio, double quantile) {
  if (value.type() != CV_32FC1 || valid.type() != CV_8UC1 || value.size() != valid.size())
    throw std::invalid_argument("LocalReliefNoise: value must be CV_32F with a CV_8U mask of the same size");
  if (cell < 4 || !(floor_sigma > 0) || !(max_ratio > 0) || !(quantile > 0 && quantile < 1))
    throw std::invalid_argument(
        "LocalReliefNoise: cell_px >= 4, floor_sigma > 0, max_ratio > 0, 0 < quantile < 1 needed");
  const bool median = quantile == 0.5;
  const int gw = (value.cols + cell - 1) / cell, gh = (value.rows + cell - 1) / cell;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat grid(gh, gw, CV_32F, cv::Scalar(nan));
  // One grid row per task: cells are independent, so the result does not depend on the threads.
  tbb::parallel_for(0, gh, [&](int gy) {
    std::vector<float> up;
    for (int gx = 0; gx < gw; ++gx) {
      up.clear();
      int seen = 0;
      // Every third pixel: a cell of 96 px still gives ~500 samples above the level.
      for (int v = gy * cell; v < std::min((gy + 1) * cell, value.rows); v += 3) {
        const float* x = value.ptr<float>(v);
        const uchar* m = valid.ptr<uchar>(v);
        for (int u = gx * cell; u < std::min((gx + 1) * cell, value.cols); u += 3) {
          if (!m[u]) continue;
          ++seen;
          const float xu = kMirrored ? -x[u] : x[u];
          // Far above the road is structure, not noise (an obstacle's smoothed fringe, a bent model).
          if (xu > level && xu < level + max_ratio * floor_sigma) up.push_back(static_cast<float>(xu - level));
        }
      }
      // Road has about half its samples above the level; a cell with far fewer is mostly damage,
      // whose surroundings the local road correction bends: its neighbours' noise is used instead.
      if (up.size() < 20 || up.size() < 0.35 * seen) continue;
      // The median (rank n/2) as a σ; another quantile (its rank rounded down) as it is.
      if (median) {
        grid.ptr<float>(gy)[gx] = static_cast<float>(SigmaOfOneSidedMedian(LowerMedianInPlace(up)));
      } else {
        grid.ptr<float>(gy)[gx] = KthSmallestInPlace(up, QuantileRankDown(quantile, up.size()));
      }
    }
  });
  // Cells without road (obstacles, large damage, no disparity) take their neighbours' noise.
  FillEmptyCellsFromNeighbours(&grid);
  cv::patchNaNs(grid, floor_sigma);
  cv::blur(grid, grid, {3, 3}, {-1, -1}, cv::BORDER_REPLICATE);
  cv::max(grid, floor_sigma, grid);  // before interpolation: a convex combination stays above the floor
  cv::Mat full;
  cv::resize(grid, full, {gw * cell, gh * cell}, 0, 0, cv::INTER_LINEAR);
  return full(cv::Rect({}, value.size()));  // a view: no copy
}

}  // namespace

cv::Mat LocalReliefNoise(const cv::Mat& value, const cv::Mat& valid, double level, int cell, double floor_sigma,
                         double max_ratio, double quantile) {
  return NoiseOf<false>(value, valid, level, cell, floor_sigma, max_ratio, quantile);
}

cv::Mat LocalReliefNoiseBelow(const cv::Mat& value, const cv::Mat& valid, double level, int cell_px, double floor_sigma,
                              double max_ratio) {
  return NoiseOf<true>(value, valid, -level, cell_px, floor_sigma, max_ratio, 0.5);
}

}  // namespace rs
