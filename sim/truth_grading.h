#pragma once
// True severity of simulated damage, graded the way users expect (MISSION.md,
// "Severity grading").

#include <string>

namespace rs::sim {

/// ASTM D6433 pothole severity from max depth and mean diameter:
///   depth 13-25 mm: L, L, M;  25-50 mm: L, M, H;  > 50 mm: M, M, H
///   for mean diameters 100-200, 200-450, 450-750 mm. Wider than 750 mm: M if
///   depth <= 25 mm else H (counted as area / 0.5 m2 potholes). Returns "" when
///   the hole is not a pothole by the standard (depth < 13 mm or diameter < 100 mm).
std::string PotholeSeverityAstm(double max_depth_m, double mean_diameter_m);

/// FHWA LTPP crack severity by mean width: L <= 6 mm, M 6-19 mm, H > 19 mm.
std::string CrackSeverityFhwa(double width_m);

}  // namespace rs::sim
