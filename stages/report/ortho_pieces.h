#pragma once
// The orthophoto sized for a screen: the surface stage's ortho.tif read at the finest of its
// overview levels whose road pixels fit a budget, cut into square pieces written as images with
// transparency where the orthophoto has no data. Empty pieces are not written. A browser shows
// each piece as an image overlay at its bounds.

#include <filesystem>
#include <string>
#include <vector>

namespace rs {

struct OrthoPiece {
  std::string file;  ///< relative to the report folder, e.g. "ortho/0_3.webp"
  double x_min = 0, y_min = 0, x_max = 0, y_max = 0;  ///< bounds in the ortho's CRS
};

struct OrthoPieces {
  double cell_x = 0, cell_y = 0;  ///< ground size of one written pixel (CRS units)
  int level = 0;                  ///< overview level used (0 = full resolution)
  long long pixels = 0;           ///< pixels with data written
  std::vector<OrthoPiece> pieces;
};

struct OrthoPieceOptions {
  long long max_pixels = 8'000'000;  ///< budget of pixels with data
  int piece_px = 1024;               ///< side of a piece
  int quality = 80;                  ///< WebP/JPEG quality
};

/// Writes the pieces of `ortho_tif` under report_dir/ortho/. WebP with alpha when this OpenCV can
/// write it, PNG otherwise. Throws InputError naming the file on an unreadable GeoTIFF, WriteError
/// on a failed write.
OrthoPieces WriteOrthoPieces(const std::filesystem::path& ortho_tif, const std::filesystem::path& report_dir,
                             const OrthoPieceOptions& options);

}  // namespace rs
