#pragma once
// Data types shared by the damage algorithms: camera geometry, one measured
// damage instance, and its severity grades. Units are in the field names.

#include <opencv2/core.hpp>

#include "formats/rectified_stereo.h"
#include "survey/grading/severity_rules.h"

#include <limits>
#include <string>
#include <vector>

namespace rs {

/// Marks a measurement that could not be made (e.g. no calibration).
inline constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

/// Kind of damage an instance was classified as.
enum class DamageType { kPothole, kCrack, kOther };
/// "pothole", "crack", "other".
const char* DamageTypeName(DamageType type);

/// One damage instance with its measurements. Metric fields are NaN where
/// unknown (no calibration) so that a missing value is never a silent zero.
struct DamageInstance {
  int id = 0;  ///< label value in the instance image (1..65535)
  DamageType type = DamageType::kOther;
  std::vector<cv::Point> outline_px;       ///< outer boundary, pixel corners of the label
  std::vector<cv::Point3d> outline_cam_m;  ///< outline on the road surface, camera frame, m
  int pixel_count = 0;
  double area_m2 = kUnknown;  ///< area projected on the road plane
  /// Deepest point below the road surface: the best estimate. Where the near rim hides part of
  /// the floor (oblique views, floor_visibility.h) the seen profile completed behind the rim;
  /// else what the frame sees (= max_depth_seen_m).
  double max_depth_m = kUnknown;
  double max_depth_seen_m = kUnknown;  ///< deepest point the frame sees (99th percentile of the seen depths)
  double mean_depth_m = kUnknown;      ///< mean depth below the road surface over the seen surface
  /// Volume between road surface and damage: the best estimate (the seen volume plus the
  /// completed part the near rim hides, floor_visibility.h).
  double volume_m3 = kUnknown;
  double volume_seen_m3 = kUnknown;         ///< volume of the surface the frame sees (a lower bound)
  double equivalent_diameter_m = kUnknown;  ///< sqrt(4·area/π)
  double max_diameter_m = kUnknown;         ///< largest distance between two outline points on the road plane
  double length_m = kUnknown;               ///< cracks: skeleton length
  double mean_width_m = kUnknown;           ///< cracks: mean width along the skeleton
  double max_width_m = kUnknown;            ///< cracks: largest width along the skeleton
  double range_m = kUnknown;                ///< mean camera distance Z of the road under the instance
  double sigma_depth_m = kUnknown;          ///< stereo depth uncertainty σ_Z = Z²·σ_d/(f·B) at range_m
  /// Depressions: σ of area_m2, the outline moved by its position uncertainty (measurement_sigma.h).
  double sigma_area_m2 = kUnknown;
  /// Depressions: σ of volume_seen_m3 (depth noise over the region, the outline's uncertainty at
  /// the mean depth); where the floor may be hidden volume_upper_m3 bounds the rest.
  double sigma_volume_m3 = kUnknown;
  double confidence = 0;  ///< 0..1, see docs/stages/damage.md
  /// Line of sight over the near rim (floor_visibility.h; depressions only). false: the rim
  /// may hide part of the floor from this viewpoint: max_depth_seen_m is then a lower bound,
  /// max_depth_bound_m an upper one and max_depth_m the estimate between them.
  bool floor_visible = true;
  double grazing_angle_deg = kUnknown;  ///< elevation of the rays over the near rim above the road
  double hidden_length_m = kUnknown;    ///< longest stretch behind the near rim no ray reaches (along the view)
  double max_depth_bound_m = kUnknown;  ///< floor hidden: largest depth the geometry allows (incl. 2 σ); NaN when seen
  /// Where the rim's shadow may hide volume (> 5 % of volume_seen_m3, or the floor hidden): the
  /// volume with that shadow filled to the bound (+2 σ); the true volume lies in
  /// [volume_seen_m3 − 2 σ_Z·area_m2, volume_upper_m3]. NaN when the volume is seen.
  double volume_upper_m3 = kUnknown;
  SeverityGrade astm;             ///< ASTM D6433 pothole grade (potholes only)
  SeverityGrade fhwa;             ///< FHWA LTPP grade (potholes and cracks)
  bool intervention = false;      ///< exceeds the configured intervention thresholds
  std::string intervention_rule;  ///< why (or why not) it needs intervention
};

}  // namespace rs
