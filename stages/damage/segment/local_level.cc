#include "stages/damage/segment/local_level.h"

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "stages/damage/road/grid_fill.h"
#include "stages/damage/segment/wall_test.h"
#include "survey/stats/order_statistic.h"

namespace rs {
namespace {

// Clipped median of `vals` (reordered): values further than k·σ from the median are dropped and
// the median retaken until the kept set stops changing.
float ClippedMedian(std::vector<float>& vals, double k_sigma) {
  const float band = static_cast<float>(k_sigma);
  float median = LowerMedianInPlace(vals);
  for (int round = 0; round < 8; ++round) {
    const size_t before = vals.size();
    vals.erase(std::remove_if(vals.begin(), vals.end(), [&](float x) { return std::abs(x - median) > band; }),
               vals.end());
    if (vals.empty() || vals.size() == before) break;
    median = LowerMedianInPlace(vals);
  }
  return median;
}

// 3×3 median of a mesh (edges replicated): a cell a depression fills, alone or in a 2×2 block,
// is outvoted by the road around it.
cv::Mat MedianOfNeighbours(const cv::Mat& grid) {
  cv::Mat out(grid.size(), CV_32F);
  std::vector<float> nb;
  for (int y = 0; y < grid.rows; ++y)
    for (int x = 0; x < grid.cols; ++x) {
      nb.clear();
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          nb.push_back(grid.at<float>(std::clamp(y + dy, 0, grid.rows - 1), std::clamp(x + dx, 0, grid.cols - 1)));
      std::nth_element(nb.begin(), nb.begin() + 4, nb.end());
      out.at<float>(y, x) = nb[4];
    }
  return out;
}

}  // namespace

cv::Mat LocalReliefLevel(const ReliefImage& relief, int cell_px, double sigma, double clip_sigma,
                         const cv::Mat& exclude) {
  const cv::Mat& value = relief.value;
  if (value.type() != CV_32FC1 || relief.valid.type() != CV_8UC1 || relief.valid.size() != value.size())
    throw std::invalid_argument("LocalReliefLevel: relief must be CV_32F with a CV_8U mask of the same size");
  if (!exclude.empty() && (exclude.type() != CV_8UC1 || exclude.size() != value.size()))
    throw std::invalid_argument("LocalReliefLevel: exclude must be CV_8U of the relief's size");
  if (cell_px < 2 || !(sigma > 0) || !(clip_sigma > 0))
    throw std::invalid_argument("LocalReliefLevel: cell must be >= 2 px, sigma and clip > 0");
  const int gw = (value.cols + cell_px - 1) / cell_px, gh = (value.rows + cell_px - 1) / cell_px;
  cv::Mat grid(gh, gw, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  // Every second pixel in u and v: thousands of samples per cell, a quarter of the work.
  const int step = cell_px >= 16 ? 2 : 1;
  tbb::parallel_for(0, gh, [&](int gy) {
    std::vector<float> vals;
    for (int gx = 0; gx < gw; ++gx) {
      vals.clear();
      int seen = 0;
      const int u1 = std::min((gx + 1) * cell_px, value.cols), v1 = std::min((gy + 1) * cell_px, value.rows);
      for (int v = gy * cell_px; v < v1; v += step) {
        const float* x = value.ptr<float>(v);
        const uchar* m = relief.valid.ptr<uchar>(v);
        const uchar* ex = exclude.empty() ? nullptr : exclude.ptr<uchar>(v);
        for (int u = gx * cell_px; u < u1; u += step) {
          ++seen;
          if (m[u] && !(ex && ex[u])) vals.push_back(x[u]);
        }
      }
      if (vals.size() * 4 < static_cast<size_t>(seen) || vals.empty()) continue;
      grid.at<float>(gy, gx) = ClippedMedian(vals, clip_sigma * sigma);
    }
  });
  FillEmptyCellsFromNeighbours(&grid);
  if (cv::countNonZero(grid == grid) == 0) return cv::Mat(value.size(), CV_32F, cv::Scalar(0));
  grid = MedianOfNeighbours(grid);
  // Bilinear between cell centres: resize maps cell centres to the centres of their pixel blocks.
  cv::Mat full;
  cv::resize(grid, full, {gw * cell_px, gh * cell_px}, 0, 0, cv::INTER_LINEAR);
  return full(cv::Rect({}, value.size())).clone();
}

}  // namespace rs

namespace rs {
namespace {

// The relief with its local level replaced by the constant `level`.
ReliefImage Flattened(const ReliefImage& relief, const cv::Mat& local_level, double level) {
  ReliefImage out;
  out.valid = relief.valid;
  out.row_elongation = relief.row_elongation;
  out.value = relief.value - local_level + level;
  return out;
}

// Pixels to leave out of the level: the depressions found, closed over a cell and with their
// holes filled (a pothole wider than the cells shows first as broken parts of its rim, the
// level having followed its floor), grown by half a cell.
cv::Mat ExclusionOf(const cv::Mat& labels, int cell) {
  cv::Mat mask = labels != 0;
  const auto disk = [](int r) { return cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}); };
  cv::Mat padded;  // closed with a margin, so a rim cut by the image border still closes
  cv::copyMakeBorder(mask, padded, cell, cell, cell, cell, cv::BORDER_CONSTANT, 0);
  cv::morphologyEx(padded, padded, cv::MORPH_CLOSE, disk(cell));
  mask = padded(cv::Rect(cell, cell, mask.cols, mask.rows)).clone();
  FillHoles(mask);
  cv::dilate(mask, mask, disk(std::max(1, cell / 2)));
  return mask;
}

}  // namespace

DepressionSegmentation SegmentOnLocalLevel(const ReliefImage& relief, const SegmentOptions& o,
                                           std::optional<ReliefScale> scale) {
  const int cell = o.level_cell_px;
  if (cell <= 0) return SegmentDepressions(relief, o, cv::Mat(), scale);
  const ReliefScale global = scale ? *scale : EstimateReliefScale(relief);
  ReliefImage flat = Flattened(relief, LocalReliefLevel(relief, cell, global.sigma), global.road_level);
  DepressionSegmentation out = SegmentDepressions(flat, o, cv::Mat(), EstimateReliefScale(flat));
  // Level again without what was found, until the excluded area stops growing (a pothole many
  // cells wide takes two rounds: its rim, then the whole hole).
  int excluded = 0;
  for (int round = 0; round < 3 && out.count > 0; ++round) {
    const cv::Mat exclude = ExclusionOf(out.labels, cell);
    const int n = cv::countNonZero(exclude);
    if (n <= excluded) break;
    excluded = n;
    flat = Flattened(relief, LocalReliefLevel(relief, cell, global.sigma, 3.0, exclude), global.road_level);
    out = SegmentDepressions(flat, o, cv::Mat(), EstimateReliefScale(flat));
  }
  // Road shape the level did not follow (a rut narrower than two cells) crosses the threshold
  // on a slope like the road's own roughness; a pothole's wall drops far more steeply.
  if (o.min_wall_steepness > 0 && out.count > 0) {
    const ReliefSlope slope = MeasureReliefSlope(flat.value, flat.valid, out.labels);
    out.dropped_gentle =
        DropInstancesWithoutWall(&out.labels, &out.count, WallSteepness(slope, out.labels, out.count), o.min_wall_steepness);
  }
  return out;
}

}  // namespace rs
