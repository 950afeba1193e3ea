#pragma once
// Small holes in a fused tile (a painted line the matcher lost, a glare spot) filled from their
// rim, so the DSM has no gap a road user would not see; the filled cells keep a view count of 0
// (dsm_count.tif says they are interpolated) and a σ raised by the gap they bridge.

#include "stages/surface/tile_accumulator.h"

namespace rs {

/// Fills every empty region of `t` that lies inside the tile (touches no tile edge) and is at most
/// `max_width_cells` wide (twice its largest inscribed radius): heights peeled in from the rim (each
/// round the known neighbours' mean), colours inpainted (OpenCV Telea), σ = the rim's largest σ plus the rim's height spread. Returns the cells filled.
int FillSmallHoles(FusedTile* t, double max_width_cells);

}  // namespace rs
