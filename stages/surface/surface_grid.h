#pragma once
// The surface products' raster: a north-up grid of square cells in the survey's CRS, cut into
// square tiles that are fused, written and meshed one at a time (memory does not grow with the
// survey's length). Row 0 is the northern edge; a cell's centre is
// (x_min + (col + 0.5) cell, y_max - (row + 0.5) cell).

#include <cmath>
#include <cstdint>

namespace rs {

struct SurfaceGrid {
  double x_min = 0, y_max = 0;  ///< CRS coordinates of the grid's north-west corner
  double cell = 0.01;           ///< cell size, CRS metres
  int cols = 0, rows = 0;       ///< grid size, cells
  int tile = 256;               ///< tile size, cells

  int tiles_across() const { return (cols + tile - 1) / tile; }
  int tiles_down() const { return (rows + tile - 1) / tile; }
  int tile_count() const { return tiles_across() * tiles_down(); }
  /// Column and row of the cell holding (x, y); may lie outside the grid.
  int64_t ColOf(double x) const { return static_cast<int64_t>(std::floor((x - x_min) / cell)); }
  int64_t RowOf(double y) const { return static_cast<int64_t>(std::floor((y_max - y) / cell)); }
  bool Contains(int64_t col, int64_t row) const { return col >= 0 && row >= 0 && col < cols && row < rows; }
  /// Index of the tile holding cell (col, row), which must be inside the grid.
  int TileOf(int64_t col, int64_t row) const {
    return static_cast<int>(row / tile) * tiles_across() + static_cast<int>(col / tile);
  }
  double CellCentreX(int64_t col) const { return x_min + (static_cast<double>(col) + 0.5) * cell; }
  double CellCentreY(int64_t row) const { return y_max - (static_cast<double>(row) + 0.5) * cell; }
};

}  // namespace rs
