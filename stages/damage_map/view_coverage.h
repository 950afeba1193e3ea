#pragma once
// Which examined frames had a damage in view. A damage is a lasting feature of the road: every
// view that looks at it sees it, while a spurious detection (texture, a stereo mismatch) is
// independent noise that the other views of the same spot do not repeat. The detection rate
// (views that detected it / views that had it in view) separates the two.

#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "formats/rectified_stereo.h"

namespace rs {

/// A frame the damage stage examined, placed on the map.
struct ExaminedView {
  int64_t frame = 0;
  Eigen::Affine3d camera_from_enu = Eigen::Affine3d::Identity();  ///< left camera from local ENU (similarity)
  double analysed_range_m = std::numeric_limits<double>::infinity();  ///< damage beyond was not looked for
};

/// True when `p_enu` lies in front of the view's left camera, within its analysed range and at
/// least `border_px` inside its image (camera: the rectified left camera with its image size).
bool InView(const ExaminedView& view, const RectifiedStereo& camera, const Eigen::Vector3d& p_enu, int border_px);

/// The frames of `views` that had `p_enu` in view (ascending as given).
std::vector<int64_t> FramesInView(const std::vector<ExaminedView>& views, const RectifiedStereo& camera,
                                  const Eigen::Vector3d& p_enu, int border_px);

/// The point halfway along a polyline (its first point when it has no length).
Eigen::Vector3d PolylineMidpoint(const std::vector<Eigen::Vector3d>& line);

}  // namespace rs
