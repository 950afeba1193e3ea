#pragma once
// Stage "surface": the road's elevation model, orthophoto and mesh in the survey's CRS. Every
// frame's valid disparity on the road (damage included, obstacles left out) is placed with the
// georeferenced cameras and fused, tile by tile, into a height grid with per-cell σ and view
// count; published as GeoTIFFs (dsm, ortho, σ, count) and a decimated mesh (PLY, OBJ).
// Docs: docs/stages/surface.md.

#include "survey/stage.h"

namespace rs {

struct SurfaceOptions {
  double cell_m = 0.01;              ///< finest grid cell; coarser when the frames' pixels are larger
  int tile_cells = 256;              ///< tile side, cells (also the GeoTIFF tile)
  int keep_views = 12;               ///< best observations kept per cell for the robust fusion
  int min_views = 2;                 ///< cells seen by fewer views are left empty
  int damage_margin_px = 10;         ///< sharp disparity within this distance of detected damage
  double fill_holes_m = 0.15;        ///< empty regions up to this wide are filled from their rim
  double max_range_m = 0;            ///< pixels deeper than this are not fused (0: no limit)
  double disparity_sigma_px = 0;     ///< fixed disparity σ (0: each frame's road-fit residual)
  double min_disparity_sigma_px = 0.1;  ///< floor of the per-frame disparity σ
  int resident_frames = 3;           ///< a tile no frame touched for this many frames is spilled to disk
  bool mesh = true;                  ///< write mesh.ply / mesh.obj
  double mesh_max_height_error_m = 0.002;  ///< decimation keeps every grid vertex this close (vertically)

  void Check() const;
  static const OptionTable<SurfaceOptions>& Table();
};

class SurfaceStage : public TypedStage<SurfaceStage, SurfaceOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const SurfaceOptions& options) const;
};

}  // namespace rs
