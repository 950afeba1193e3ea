#pragma once
// One tile of the height grid while frames are fused into it: per cell, the K observations with
// the smallest height uncertainty (nearest, most nadir views), how many views saw it, and the
// colour of its best view. Keeping the best few rather than a running mean lets the final fusion
// be robust (a weighted median, then Huber re-weighting) without holding every view.

#include <cstdint>
#include <filesystem>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace rs {

/// One frame's estimate of one cell.
struct CellObservation {
  float height_m = 0;
  float sigma_m = 0;        ///< 1-σ height uncertainty of this view
  uint8_t bgr[3] = {0, 0, 0};
};

/// A finished tile: CV_32F heights (NaN = no view), CV_32F σ (NaN likewise), CV_16U view counts,
/// CV_8UC3 colour of each cell's best view.
struct FusedTile {
  cv::Mat height_m, sigma_m, count, colour;
};

/// Robust fusion of one cell's observations: the inverse-variance weighted median, then Huber
/// re-weighting (k = 2 σ) around it; σ is the weighted mean's, scaled up by the observed spread
/// when the views disagree more than their σ say. Returns false when `n` is 0.
bool FuseCell(const CellObservation* obs, int n, float* height_m, float* sigma_m);

class TileAccumulator {
 public:
  /// `cells`: cells in the tile; `keep`: observations kept per cell (the best by σ).
  TileAccumulator(int cells, int keep);

  void Add(int cell, const CellObservation& o);
  /// Fuses every cell seen by at least `min_views` views (the others are left empty, count 0).
  /// `side` is the tile's width in cells (cells = side²).
  FusedTile Fuse(int side, int min_views = 1) const;

  /// Writes / reads the whole state (spilling a tile to disk while the flight is elsewhere).
  /// Throw WriteError / std::runtime_error naming the file.
  void Save(const std::filesystem::path& path) const;
  static TileAccumulator Load(const std::filesystem::path& path);

  int cells() const { return cells_; }
  int keep() const { return keep_; }
  size_t bytes() const;

 private:
  int cells_ = 0, keep_ = 0;
  std::vector<CellObservation> obs_;  ///< cells × keep, first used_[c] of each cell valid
  std::vector<uint8_t> used_;
  std::vector<uint16_t> seen_;        ///< views that saw the cell (saturating)
};

}  // namespace rs
