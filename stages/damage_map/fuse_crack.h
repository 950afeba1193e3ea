#pragma once
// Fusion of one crack's views into one continuous polyline: the views' outlines on the road are
// rasterised together (gaps up to the merge tolerance closed), thinned to a skeleton, and the
// skeleton's longest path is the crack's centreline; its length is the crack's length. Width from
// the views that see the crack whole, near range first.

#include <vector>

#include "stages/damage_map/mapped_damage.h"

namespace rs {

struct CrackFusionOptions {
  double cell_m = 0.005;     ///< raster cell of the merged outline (coarser for very long cracks)
  double gap_m = 0.05;       ///< gaps between views closed up to this size
  double simplify_m = 0.01;  ///< polyline simplification tolerance (Douglas-Peucker)
};

/// The centreline of the union of `rings` (local ENU; z interpolated from the nearest ring point).
std::vector<Eigen::Vector3d> MergedCenterline(const std::vector<const std::vector<Eigen::Vector3d>*>& rings,
                                              const CrackFusionOptions& options);

/// Polyline length on the road (3D).
double PolylineLength(const std::vector<Eigen::Vector3d>& line);

/// Fuses the views `members` of one crack; `bridges` (local ENU polylines, may be empty) join
/// pieces of it across gaps no view detected (link_cracks.h). Severity is left to the caller.
MappedDamage FuseCrack(const std::vector<MapObservation>& obs, const std::vector<int>& members,
                       const CrackFusionOptions& options,
                       const std::vector<std::vector<Eigen::Vector3d>>& bridges = {});

}  // namespace rs
