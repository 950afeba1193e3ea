#pragma once
// A road-surface mesh from a height grid: each block is triangulated at the cell centres,
// decimated under a bound on the vertical error, and streamed to binary PLY and OBJ, so a survey
// of any length is meshed in bounded memory (one block of at most 257 x 257 vertices at a time).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace rs {

struct GridMeshOptions {
  double max_height_error_m = 0.002;  ///< decimation keeps every grid vertex within this vertical distance of the mesh

  /// Throws std::invalid_argument naming the rule broken.
  void Check() const;
};

/// One block of the height grid: cell centres at x = x_min + (c + 0.5) * cell, y = y_max - (r + 0.5) * cell (CRS metres, north-up, row 0 = north).
struct HeightBlock {
  cv::Mat height_m;  ///< CV_32F, NaN = no height
  cv::Mat colour;    ///< CV_8UC3 (BGR) or CV_8UC1 grey, same size (empty = grey 128)
  double x_min = 0, y_max = 0, cell = 0;
};

struct GridMeshStats {
  int64_t grid_vertices = 0;      ///< vertices of the triangulated grid, before decimation
  int64_t grid_faces = 0;         ///< triangles of the triangulated grid, before decimation
  int64_t vertices = 0;           ///< vertices written (those on block seams once per block)
  int64_t faces = 0;              ///< triangles written
  double max_height_error_m = 0;  ///< largest vertical distance of a removed grid vertex to the mesh
  int64_t pieces = 0;             ///< blocks of at most 257 x 257 cells meshed
  double mesh_s = 0;              ///< time spent triangulating and decimating
};

/// Streams a mesh to `ply_path` (binary little-endian PLY: float x,y,z + uchar red,green,blue; faces as uchar-count int lists)
/// and `obj_path` (text OBJ: "v x y z r g b" with colours in [0,1], "f i j k"); coordinates are CRS coordinates minus `offset`.
/// Temporaries lie next to the outputs (`<ply_path>.vertices.tmp`, `<ply_path>.faces.tmp`, `<obj_path>.tmp`).
class GridMeshWriter {
 public:
  /// Creates the temporaries; throws WriteError naming the file when one cannot be created.
  GridMeshWriter(std::filesystem::path ply_path, std::filesystem::path obj_path, Eigen::Vector3d offset,
                 GridMeshOptions options = {});
  ~GridMeshWriter();  // removes unfinished files and temporaries
  GridMeshWriter(const GridMeshWriter&) = delete;
  GridMeshWriter& operator=(const GridMeshWriter&) = delete;

  /// Triangulates the block (two triangles per 2x2 group of cell centres that all have heights; a group with exactly
  /// three heights gives one triangle), decimates it with the block's outer boundary vertices locked (so adjacent
  /// blocks that share their edge row/column of cells meet without cracks), and appends it.
  /// The caller passes blocks that overlap by one row and one column of cells (a tile plus the first column/row of
  /// its right/lower neighbours), so the seams are covered. A block larger than 257 x 257 cells is meshed in pieces
  /// of that size that overlap the same way. Throws std::invalid_argument for a malformed block, WriteError when a
  /// temporary cannot be written.
  void AddBlock(const HeightBlock& block);
  /// AddBlock for several blocks, meshed in parallel and appended in the order given (the
  /// output is the same as adding them one by one).
  void AddBlocks(const std::vector<HeightBlock>& blocks);

  /// Writes the headers and concatenates the temporaries; throws WriteError naming the file on failure.
  GridMeshStats Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rs
