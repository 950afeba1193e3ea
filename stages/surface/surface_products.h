#pragma once
// The surface stage's files: the four GeoTIFFs written tile by tile as tiles are finished
// (dsm.tif heights, dsm_sigma.tif, dsm_count.tif, ortho.tif), and the mesh built afterwards from
// the finished DSM and orthophoto, a tile (plus its neighbours' first row and column) at a time.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "formats/geo/geotiff.h"
#include "stages/surface/surface_grid.h"
#include "stages/surface/tile_accumulator.h"

namespace rs {

inline constexpr double kDsmNodata = -9999.0;

/// The survey CRS as the GeoTIFFs state it.
struct RasterCrs {
  int epsg = 0;           ///< horizontal EPSG code (0: local tangent plane, described in `citation`)
  int vertical_epsg = 0;  ///< 5773 for EGM96 heights, else 0
  std::string citation;   ///< the CRS's name or description
  std::string heights;    ///< what heights are measured from, in words
};

struct SurfaceTotals {
  int64_t tiles = 0, cells_filled = 0;
  int64_t cells_interpolated = 0;  ///< of the filled cells, small holes filled from their rim
  double sigma_sum_m = 0;  ///< over filled cells
  std::vector<int> tiles_written;
};

class SurfaceRasters {
 public:
  SurfaceRasters(const std::filesystem::path& dir, const SurfaceGrid& grid, const RasterCrs& crs);
  /// Writes one finished tile into the four rasters.
  void WriteTile(int tile, const FusedTile& t);
  /// Builds the overviews and closes the files.
  void Finish();
  const SurfaceTotals& totals() const { return totals_; }

 private:
  SurfaceGrid grid_;
  std::unique_ptr<GeoTiffWriter> dsm_, sigma_, count_, ortho_;
  SurfaceTotals totals_;
};

struct MeshSummary {
  int64_t grid_vertices = 0, grid_faces = 0, vertices = 0, faces = 0;
  double max_height_error_m = 0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};

/// mesh.ply and mesh.obj from dsm.tif and ortho.tif in `dir` over the written tiles; coordinates
/// relative to `offset`.
MeshSummary WriteSurfaceMesh(const std::filesystem::path& dir, const SurfaceGrid& grid, const std::vector<int>& tiles,
                             const Eigen::Vector3d& offset, double max_height_error_m);

}  // namespace rs
