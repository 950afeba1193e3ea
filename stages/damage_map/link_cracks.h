#pragma once
// Cracks seen in pieces: a crack's contrast dips along its length (where a hairline narrows, or
// the texture beside it is busy), and where it dips in every view the merged views still leave
// pieces on the map, end to end along one line. Pieces whose ends face each other across a short
// gap are one crack.

#include <vector>

#include <Eigen/Core>

namespace rs {

struct CrackLinkOptions {
  double max_gap_m = 0.25;      ///< largest gap bridged between two pieces' ends (0: none)
  double max_angle_deg = 30.0;  ///< largest angle between the gap and either end's direction
  double tangent_m = 0.10;      ///< arc length over which an end's direction is taken
};

/// A polyline end: its point and its outward direction (unit, in the road plane), taken over
/// `tangent_m` of arc length (or the whole line where it is shorter).
struct CrackEnd {
  Eigen::Vector2d point, outward;
};

/// The two ends of `line` (local ENU); the first is at line.front(). Empty for fewer than two points.
std::vector<CrackEnd> CrackEnds(const std::vector<Eigen::Vector3d>& line, double tangent_m);

/// True when ends `a` and `b` of two pieces face each other: at most max_gap_m apart, and the gap
/// from a to b within max_angle_deg of a's outward direction and of the reverse of b's. Ends closer
/// than `touch_m` (the views' merge tolerance) are joined whatever their direction.
bool EndsFace(const CrackEnd& a, const CrackEnd& b, const CrackLinkOptions& options, double touch_m);

/// One link's gap: the two ends it joins as a segment (local ENU), and one of the two pieces.
struct CrackBridge {
  int piece = 0;
  std::vector<Eigen::Vector3d> segment;
};

/// Groups of pieces (indices into `lines`, each group ascending, groups in order of their first
/// piece) linked end to end by EndsFace, transitively; every link's gap in `bridges`.
std::vector<std::vector<int>> LinkCrackPieces(const std::vector<std::vector<Eigen::Vector3d>>& lines,
                                              const CrackLinkOptions& options, double touch_m,
                                              std::vector<CrackBridge>* bridges);

}  // namespace rs
