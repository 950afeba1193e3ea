#pragma once
// Keypoints bucketed by pyramid level and image cell, and the cells an epipolar band crosses:
// the candidate search of keyframe-to-keyframe triangulation (CreateNewMapPoints) scans those
// cells instead of every keypoint of the other keyframe.

#include <vector>

#include <opencv2/core/types.hpp>

namespace rs {

class EpipolarGrid {
 public:
  struct Entry {
    float x, y;  ///< level-0 keypoint position, px
    int j;       ///< keypoint index
  };
  static constexpr int kCellPx = 32;

  EpipolarGrid(int width, int height, int levels);
  void Add(const cv::KeyPoint& kp, int index);
  /// Cells (row-major index) within `half_width_px` of the line a x + b y + c = 0, each once.
  /// Conservative: may include a few cells just outside the band.
  void CellsAlongLine(double a, double b, double c, double half_width_px, std::vector<int>* cells) const;
  const std::vector<Entry>& cell(int level, int index) const { return cells_[level][index]; }
  int cols() const { return cols_; }
  int rows() const { return rows_; }

 private:
  int cols_ = 0, rows_ = 0;
  std::vector<std::vector<std::vector<Entry>>> cells_;  // [level][cell]
};

}  // namespace rs
