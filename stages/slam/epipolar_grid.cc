#include "stages/slam/epipolar_grid.h"

#include <algorithm>
#include <cmath>

namespace rs {

EpipolarGrid::EpipolarGrid(int width, int height, int levels)
    : cols_(std::max(1, (width + kCellPx - 1) / kCellPx)), rows_(std::max(1, (height + kCellPx - 1) / kCellPx)) {
  cells_.assign(std::max(1, levels), std::vector<std::vector<Entry>>(static_cast<size_t>(cols_) * rows_));
}

void EpipolarGrid::Add(const cv::KeyPoint& kp, int index) {
  const int level = std::clamp(kp.octave, 0, static_cast<int>(cells_.size()) - 1);
  const int cx = std::clamp(static_cast<int>(kp.pt.x) / kCellPx, 0, cols_ - 1);
  const int cy = std::clamp(static_cast<int>(kp.pt.y) / kCellPx, 0, rows_ - 1);
  cells_[level][static_cast<size_t>(cy) * cols_ + cx].push_back({kp.pt.x, kp.pt.y, index});
}

void EpipolarGrid::CellsAlongLine(double a, double b, double c, double half_width_px, std::vector<int>* cells) const {
  cells->clear();
  const double n = std::hypot(a, b);
  if (!(n > 0)) return;
  // Walk along the axis the line advances on fastest; per column (row) of cells the band covers the
  // line's extent over it plus half_width / |cos| on either side, widened by half a cell for safety.
  const bool along_x = std::abs(b) >= std::abs(a);
  const int steps = along_x ? cols_ : rows_, span = along_x ? rows_ : cols_;
  const double p = along_x ? a : b, q = along_x ? b : a;  // line: p * s + q * t + c = 0, t the cross axis
  const double margin = half_width_px * n / std::abs(q) + 0.5 * kCellPx;
  for (int k = 0; k < steps; ++k) {
    const double s0 = k * kCellPx - 0.5 * kCellPx, s1 = (k + 1) * kCellPx + 0.5 * kCellPx;
    const double t0 = -(p * s0 + c) / q, t1 = -(p * s1 + c) / q;
    // Clamped in double first: a line far off the image gives t beyond int range.
    const double lo = std::max(std::min(t0, t1) - margin, 0.0);
    const double hi = std::min(std::max(t0, t1) + margin, static_cast<double>(span * kCellPx - 1));
    if (!(lo <= hi)) continue;
    const int c0 = static_cast<int>(lo) / kCellPx, c1 = static_cast<int>(hi) / kCellPx;
    for (int m = c0; m <= c1; ++m) cells->push_back(along_x ? m * cols_ + k : k * cols_ + m);
  }
}

}  // namespace rs
