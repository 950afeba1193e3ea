#pragma once
// Severity grading rules of road damage on measured figures: the ASTM D6433 pothole matrix, the
// FHWA LTPP pothole and crack levels, and a configurable intervention flag. Each grade carries the
// rule that decided it, in words, so a report can be audited. Shared by the damage stage (one
// frame's measurement) and the damage map (the fused measurement of every view).

#include <string>

#include "survey/options.h"

namespace rs {

/// A severity level; kNone = below the table's smallest graded size.
enum class SeverityLevel { kNone, kLow, kMedium, kHigh };
/// "none", "low", "medium", "high".
const char* SeverityLevelName(SeverityLevel level);

/// One grade and the rule that decided it, e.g.
/// "ASTM D6433: max depth 32 mm in (25, 50] mm, mean diameter 310 mm in (200, 450] mm -> medium".
struct SeverityGrade {
  SeverityLevel level = SeverityLevel::kNone;
  double equivalent_count = 0;  ///< ASTM: potholes counted (area / 0.5 m² when wider than 750 mm)
  std::string rule;
};

/// Whether a damage needs intervention, and why (or why not).
struct InterventionGrade {
  bool needed = false;
  std::string rule;
};

/// Severity tables and intervention thresholds. Defaults: ASTM D6433 and FHWA
/// LTPP as in MISSION.md; intervention: UK 40 mm depth and 300 mm width.
struct SeverityOptions {
  double astm_depth_low_m = 0.013;  ///< ASTM depth bins: (13, 25], (25, 50], > 50 mm
  double astm_depth_mid_m = 0.025;
  double astm_depth_high_m = 0.050;
  double astm_diameter_min_m = 0.100;  ///< ASTM diameter bins: [100, 200], (200, 450], (450, 750] mm
  double astm_diameter_mid1_m = 0.200;
  double astm_diameter_mid2_m = 0.450;
  double astm_diameter_max_m = 0.750;  ///< wider: counted as area / astm_equivalent_area_m2 potholes
  double astm_equivalent_area_m2 = 0.5;
  double fhwa_pothole_min_diameter_m = 0.150;  ///< FHWA: smaller depressions are not potholes
  double fhwa_pothole_low_m = 0.025;           ///< FHWA pothole depth: low ≤ 25, moderate ≤ 50, high > 50 mm
  double fhwa_pothole_mid_m = 0.050;
  double fhwa_crack_low_m = 0.006;  ///< FHWA crack width: low ≤ 6, moderate ≤ 19, high > 19 mm
  double fhwa_crack_mid_m = 0.019;
  double intervention_depth_m = 0.040;        ///< potholes at least this deep ...
  double intervention_width_m = 0.300;        ///< ... and at least this wide need intervention
  double intervention_crack_width_m = 0.019;  ///< cracks at least this wide need intervention
  void Check() const;
  static const OptionTable<SeverityOptions>& Table();
};

/// ASTM D6433 pothole: max depth × average diameter matrix (depth bins
/// [13, 25], (25, 50], > 50 mm; diameter bins [100, 200], (200, 450], (450, 750] mm);
/// wider than 750 mm: area / 0.5 m² equivalent potholes, medium if depth ≤ 25 mm
/// else high. Shallower or narrower than the table: level none.
SeverityGrade GradeAstmPothole(double max_depth_m, double average_diameter_m, double area_m2,
                               const SeverityOptions& options);

/// FHWA LTPP pothole: diameter ≥ 150 mm, depth low ≤ 25, moderate ≤ 50, high > 50 mm.
SeverityGrade GradeFhwaPothole(double max_depth_m, double diameter_m, const SeverityOptions& options);

/// FHWA LTPP crack by mean width: low ≤ 6, moderate ≤ 19, high > 19 mm.
SeverityGrade GradeFhwaCrack(double mean_width_m, const SeverityOptions& options);

/// A depression needs intervention when it is at least intervention_depth_m deep and
/// intervention_width_m wide (largest extent on the road plane).
InterventionGrade GradeDepressionIntervention(double max_depth_m, double max_width_m, const SeverityOptions& options);

/// A crack needs intervention when its widest point is at least intervention_crack_width_m.
InterventionGrade GradeCrackIntervention(double max_width_m, const SeverityOptions& options);

}  // namespace rs
