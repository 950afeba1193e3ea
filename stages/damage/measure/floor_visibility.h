#pragma once
// Line of sight over a depression's near rim: from an oblique viewpoint (a car's camera
// 1.5 m high sees the road at 12-17° at 5-7 m) the near rim hides the floor of a deep
// pothole, so its measured depth and volume are only what this frame can see. Per
// detection: the elevation e of the rays over the near rim, the shadow line x·tan e behind
// it (the deepest point visible at along-view distance x), whether the deepest seen surface
// extends clear of that line (floor seen) or lies along it (floor hidden), an upper bound on the
// hidden depth and volume, and an estimate of them (the hidden near wall completed from the
// seen far wall). Method and assumptions: docs/stages/damage.md
// ("Hidden floors").

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"
#include "stages/damage/road/road_surface.h"

#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// Line-of-sight result of one depression.
struct FloorVisibility {
  bool analysed = false;  ///< false: no valid depth or no road under it (fields below unknown)
  /// The deepest seen surface reaches options.floor_clearance_px rows farther from the near
  /// rim's shadow line than where it begins (exact disparity: clear of the line by that much).
  bool floor_visible = true;
  double grazing_angle_deg = kUnknown;  ///< elevation of the rays over the near rim above the road plane
  double rim_clearance_m = kUnknown;    ///< how far the deepest seen surface stands above the shadow line
  double hidden_length_m = kUnknown;    ///< longest stretch behind the near rim no ray reaches (along the view)
  double max_depth_bound_m = kUnknown;  ///< floor hidden: largest depth the geometry allows (incl. 2 σ); else NaN
  /// Floor hidden, or the shadow may hide > 5 % of the volume (the near wall's wedge behind the
  /// rim): the volume with the shadow filled to the bound (a seen floor caps it), +2 σ; else NaN.
  double volume_upper_m3 = kUnknown;
  /// Best estimates: the seen profile completed behind the near rim, per strip along the view,
  /// by the mirror image of the seen far wall about the opening's centre (where the mirror is
  /// hidden too: the circle through both rims and the grazing point, no deeper than where the
  /// far wall's declining slope reaches zero), kept between the shadow line and the bounds.
  /// Equal to the measured values where nothing is hidden.
  double max_depth_estimate_m = kUnknown;
  double volume_estimate_m3 = kUnknown;
};

/// Analyses instance `id` of `labels` (CV_16U) within `box` (its bounding box) on the road
/// model: `relief.depth_below_mm` is the seen surface's depth below the road along each pixel
/// ray, `relief.road_depth_m` where that ray crosses the road. `max_depth_m`, `volume_m3`,
/// `area_m2` and `sigma_depth_m` are the instance's measurements (MeasureDepressions).
/// Walls in the shadow are assumed no steeper on average than options.hidden_wall_slope.
FloorVisibility AnalyseFloorVisibility(const cv::Mat& labels, int id, const cv::Rect& box, const RoadRelief& relief,
                                       const RectifiedStereo& geometry, const RoadSurface& surface,
                                       const MeasureOptions& options, double max_depth_m, double volume_m3,
                                       double area_m2, double sigma_depth_m);

/// Runs AnalyseFloorVisibility on every depression of `instances` (not cracks) with a finite
/// max depth and stores the result in the instance's floor fields: max_depth_m and volume_m3
/// become the estimates, the measured values move to max_depth_seen_m and volume_seen_m3.
void AnalyseFloorVisibility(std::vector<DamageInstance>& instances, const cv::Mat& labels, const RoadRelief& relief,
                            const RectifiedStereo& geometry, const RoadSurface& surface, const MeasureOptions& options);

}  // namespace rs
