#pragma once
// One physical damage on the map: every view that saw it, and the measurements fused from the
// best of them (docs/stages/damage_map.md, "Fusion").

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "stages/damage_map/map_observation.h"
#include "survey/grading/severity_rules.h"

namespace rs {

inline constexpr double kNotMeasured = std::numeric_limits<double>::quiet_NaN();

/// A fused figure and its 1σ uncertainty.
struct FusedValue {
  double value = kNotMeasured;
  double sigma = kNotMeasured;
};

struct MappedDamage {
  int id = 0;
  std::string type;          ///< "pothole", "crack" or "other"
  std::vector<int> members;  ///< indices of its observations (ascending)
  int best = -1;             ///< index of the best view
  std::vector<int> used;     ///< the views the measurements were fused from
  std::string basis;         ///< which views were used and why, in words
  /// Depressions: the outline ring of the best view; cracks: the merged centreline. Local ENU.
  std::vector<Eigen::Vector3d> geometry_enu;
  Eigen::Vector3d centroid_enu = Eigen::Vector3d::Zero();
  bool outline_complete = true;  ///< some view saw the whole outline (else area is a lower bound)
  bool floor_visible = true;     ///< some used view saw the floor (else the depth is an interval)
  FusedValue area_m2, max_depth_m, mean_depth_m, volume_m3;
  double max_depth_seen_m = kNotMeasured;   ///< floor hidden: the interval's lower end
  double max_depth_bound_m = kNotMeasured;  ///< floor hidden: the interval's upper end
  double volume_upper_m3 = kNotMeasured;    ///< hidden volume possible: the upper bound
  double equivalent_diameter_m = kNotMeasured, max_diameter_m = kNotMeasured;
  FusedValue length_m, width_m;  ///< cracks
  double max_width_m = kNotMeasured;
  SeverityGrade astm, fhwa;
  InterventionGrade intervention;
  std::string severity = "none";  ///< the governing level: ASTM for potholes, FHWA for cracks
  double chainage_m = kNotMeasured, offset_m = kNotMeasured;
  /// Examined frames that detected it or had its centre in view, and the share that detected it.
  int views_in_view = 0;
  double detection_rate = kNotMeasured;
};

}  // namespace rs
