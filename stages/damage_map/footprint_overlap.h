#pragma once
// Do two outlines on the map show the same damage? Rasterised overlap on the road plane, tolerant
// of the pose error between the frames (a buffer) and of partial views (measured against the
// smaller footprint, so a view cut by the image border still matches the whole).

#include <vector>

#include <Eigen/Core>

namespace rs {

/// A ring's horizontal footprint (x east, y north) and its bounding box.
struct Footprint {
  std::vector<Eigen::Vector2d> ring;
  Eigen::Vector2d lo, hi;
};
Footprint FootprintOf(const std::vector<Eigen::Vector3d>& ring);

/// Fraction of the smaller footprint inside the other buffered by `tolerance_m`, on a grid of
/// `cell_m` (coarser for pairs over 2000 cells wide). 0 when the buffered boxes are apart.
double OverlapOfSmaller(const Footprint& a, const Footprint& b, double tolerance_m, double cell_m);

/// Groups footprints that overlap (OverlapOfSmaller >= min_overlap), transitively (union-find).
/// Each group lists indices into `footprints`, ascending; groups ordered by their first index.
std::vector<std::vector<int>> GroupByOverlap(const std::vector<Footprint>& footprints, double tolerance_m,
                                             double cell_m, double min_overlap);

}  // namespace rs
