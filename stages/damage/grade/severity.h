#pragma once
// Severity grading of measured damage: ASTM D6433 pothole matrix, FHWA LTPP
// levels, and a configurable intervention flag. Each grade carries the rule
// that decided it, in words, so a report can be audited.

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"

namespace rs {

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

/// Fills astm, fhwa, intervention and intervention_rule of one instance from its type and
/// measurements (average diameter = equivalent diameter; width = maximum diameter).
void GradeInstance(DamageInstance& instance, const SeverityOptions& options);

}  // namespace rs
