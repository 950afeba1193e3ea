#pragma once
// One block of the height grid, triangulated and decimated in memory (the OpenMesh part of
// GridMeshWriter, kept out of its header).

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "stages/surface/grid_mesh.h"

namespace rs {

/// A decimated block: positions are CRS minus the writer's offset, faces index `positions`.
struct BlockMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<uint8_t, 3>> rgb;
  std::vector<std::array<int32_t, 3>> faces;  ///< counter-clockwise seen from above
  int64_t grid_vertices = 0, grid_faces = 0;
  double max_height_error_m = 0;
};

/// Triangulates `block` (see GridMeshWriter::AddBlock), locks every boundary vertex (the block's
/// outer boundary and the rims of holes) and decimates under `options.max_height_error_m`.
/// Expects a checked block; meant for blocks of at most 257 x 257 cells.
BlockMesh MeshHeightBlock(const HeightBlock& block, const Eigen::Vector3d& offset, const GridMeshOptions& options);

}  // namespace rs
