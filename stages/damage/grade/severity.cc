#include "stages/damage/grade/severity.h"

#include <fmt/format.h>

#include <cmath>

namespace rs {
namespace {

double Mm(double m) { return m * 1000.0; }

}  // namespace

SeverityGrade GradeAstmPothole(double depth, double diam, double area, const SeverityOptions& o) {
  SeverityGrade g;
  if (!std::isfinite(depth) || !std::isfinite(diam)) {
    g.rule = "ASTM D6433: depth or diameter unknown -> not graded";
    return g;
  }
  if (depth < o.astm_depth_low_m || diam < o.astm_diameter_min_m) {
    g.rule = fmt::format(
        "ASTM D6433: max depth {:.0f} mm < {:.0f} mm or mean diameter {:.0f} mm < {:.0f} mm -> not a "
        "graded pothole",
        Mm(depth), Mm(o.astm_depth_low_m), Mm(diam), Mm(o.astm_diameter_min_m));
    return g;
  }
  const int di = depth <= o.astm_depth_mid_m ? 0 : depth <= o.astm_depth_high_m ? 1 : 2;
  const std::string depth_bin =
      di == 0   ? fmt::format("[{:.0f}, {:.0f}]", Mm(o.astm_depth_low_m), Mm(o.astm_depth_mid_m))
      : di == 1 ? fmt::format("({:.0f}, {:.0f}]", Mm(o.astm_depth_mid_m), Mm(o.astm_depth_high_m))
                : fmt::format("> {:.0f}", Mm(o.astm_depth_high_m));
  if (diam > o.astm_diameter_max_m) {
    g.equivalent_count = std::isfinite(area) ? area / o.astm_equivalent_area_m2 : 0.0;
    g.level = depth <= o.astm_depth_mid_m ? SeverityLevel::kMedium : SeverityLevel::kHigh;
    g.rule = fmt::format(
        "ASTM D6433: mean diameter {:.0f} mm > {:.0f} mm -> {:.2f} m² / {:.2f} m² = {:.2f} "
        "equivalent potholes, max depth {:.0f} mm {} {:.0f} mm -> {}",
        Mm(diam), Mm(o.astm_diameter_max_m), area, o.astm_equivalent_area_m2, g.equivalent_count, Mm(depth),
        depth <= o.astm_depth_mid_m ? "<=" : ">", Mm(o.astm_depth_mid_m), SeverityLevelName(g.level));
    return g;
  }
  const int wi = diam <= o.astm_diameter_mid1_m ? 0 : diam <= o.astm_diameter_mid2_m ? 1 : 2;
  const std::string diam_bin =
      wi == 0   ? fmt::format("[{:.0f}, {:.0f}]", Mm(o.astm_diameter_min_m), Mm(o.astm_diameter_mid1_m))
      : wi == 1 ? fmt::format("({:.0f}, {:.0f}]", Mm(o.astm_diameter_mid1_m), Mm(o.astm_diameter_mid2_m))
                : fmt::format("({:.0f}, {:.0f}]", Mm(o.astm_diameter_mid2_m), Mm(o.astm_diameter_max_m));
  using L = SeverityLevel;
  static const L kTable[3][3] = {{L::kLow, L::kLow, L::kMedium},       // depth [13, 25]
                                 {L::kLow, L::kMedium, L::kHigh},      // (25, 50]
                                 {L::kMedium, L::kMedium, L::kHigh}};  // > 50
  g.level = kTable[di][wi];
  g.equivalent_count = 1;
  g.rule = fmt::format("ASTM D6433: max depth {:.0f} mm in {} mm, mean diameter {:.0f} mm in {} mm -> {}", Mm(depth),
                       depth_bin, Mm(diam), diam_bin, SeverityLevelName(g.level));
  return g;
}

SeverityGrade GradeFhwaPothole(double depth, double diam, const SeverityOptions& o) {
  SeverityGrade g;
  if (!std::isfinite(depth) || !std::isfinite(diam)) {
    g.rule = "FHWA LTPP: depth or diameter unknown -> not graded";
    return g;
  }
  if (diam < o.fhwa_pothole_min_diameter_m) {
    g.rule = fmt::format("FHWA LTPP: diameter {:.0f} mm < {:.0f} mm -> not a pothole", Mm(diam),
                         Mm(o.fhwa_pothole_min_diameter_m));
    return g;
  }
  g.equivalent_count = 1;
  if (depth <= o.fhwa_pothole_low_m) {
    g.level = SeverityLevel::kLow;
    g.rule = fmt::format("FHWA LTPP pothole: depth {:.0f} mm <= {:.0f} mm -> low", Mm(depth), Mm(o.fhwa_pothole_low_m));
  } else if (depth <= o.fhwa_pothole_mid_m) {
    g.level = SeverityLevel::kMedium;
    g.rule = fmt::format("FHWA LTPP pothole: depth {:.0f} mm in ({:.0f}, {:.0f}] mm -> moderate", Mm(depth),
                         Mm(o.fhwa_pothole_low_m), Mm(o.fhwa_pothole_mid_m));
  } else {
    g.level = SeverityLevel::kHigh;
    g.rule = fmt::format("FHWA LTPP pothole: depth {:.0f} mm > {:.0f} mm -> high", Mm(depth), Mm(o.fhwa_pothole_mid_m));
  }
  return g;
}

SeverityGrade GradeFhwaCrack(double width, const SeverityOptions& o) {
  SeverityGrade g;
  if (!std::isfinite(width)) {
    g.rule = "FHWA LTPP: crack width unknown -> not graded";
    return g;
  }
  if (width <= o.fhwa_crack_low_m) {
    g.level = SeverityLevel::kLow;
    g.rule =
        fmt::format("FHWA LTPP crack: mean width {:.1f} mm <= {:.0f} mm -> low", Mm(width), Mm(o.fhwa_crack_low_m));
  } else if (width <= o.fhwa_crack_mid_m) {
    g.level = SeverityLevel::kMedium;
    g.rule = fmt::format("FHWA LTPP crack: mean width {:.1f} mm in ({:.0f}, {:.0f}] mm -> moderate", Mm(width),
                         Mm(o.fhwa_crack_low_m), Mm(o.fhwa_crack_mid_m));
  } else {
    g.level = SeverityLevel::kHigh;
    g.rule =
        fmt::format("FHWA LTPP crack: mean width {:.1f} mm > {:.0f} mm -> high", Mm(width), Mm(o.fhwa_crack_mid_m));
  }
  return g;
}

void GradeInstance(DamageInstance& d, const SeverityOptions& o) {
  d.astm = {};
  d.fhwa = {};
  if (d.type == DamageType::kCrack) {
    d.fhwa = GradeFhwaCrack(d.mean_width_m, o);
    d.intervention = std::isfinite(d.max_width_m) && d.max_width_m >= o.intervention_crack_width_m;
    d.intervention_rule = fmt::format("crack max width {:.1f} mm {} {:.0f} mm", Mm(d.max_width_m),
                                      d.intervention ? ">=" : "<", Mm(o.intervention_crack_width_m));
    return;
  }
  if (d.type == DamageType::kPothole) {
    d.astm = GradeAstmPothole(d.max_depth_m, d.equivalent_diameter_m, d.area_m2, o);
    d.fhwa = GradeFhwaPothole(d.max_depth_m, d.equivalent_diameter_m, o);
  } else {
    d.astm.rule = "ASTM D6433: not a pothole (type other)";
    d.fhwa.rule = "FHWA LTPP: not a pothole (type other)";
  }
  const bool deep = std::isfinite(d.max_depth_m) && d.max_depth_m >= o.intervention_depth_m;
  const bool wide = std::isfinite(d.max_diameter_m) && d.max_diameter_m >= o.intervention_width_m;
  d.intervention = deep && wide;
  d.intervention_rule =
      fmt::format("depth {:.0f} mm {} {:.0f} mm and width {:.0f} mm {} {:.0f} mm", Mm(d.max_depth_m), deep ? ">=" : "<",
                  Mm(o.intervention_depth_m), Mm(d.max_diameter_m), wide ? ">=" : "<", Mm(o.intervention_width_m));
}

}  // namespace rs
