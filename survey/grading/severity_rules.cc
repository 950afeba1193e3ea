#include "survey/grading/severity_rules.h"

#include <fmt/format.h>

#include <cmath>

namespace rs {
namespace {

double Mm(double m) { return m * 1000.0; }

void RequireSeverity(bool ok, const char* a, double va, const char* op, const char* b, double vb) {
  if (!ok) throw OptionError(fmt::format("severity.{} = {} violates {} {} {} ({} = {})", a, va, a, op, b, b, vb));
}

}  // namespace

const char* SeverityLevelName(SeverityLevel level) {
  switch (level) {
    case SeverityLevel::kNone: return "none";
    case SeverityLevel::kLow: return "low";
    case SeverityLevel::kMedium: return "medium";
    case SeverityLevel::kHigh: return "high";
  }
  return "none";
}

void SeverityOptions::Check() const {
  RequireSeverity(astm_depth_low_m < astm_depth_mid_m, "astm_depth_low_m", astm_depth_low_m, "<", "astm_depth_mid_m",
          astm_depth_mid_m);
  RequireSeverity(astm_depth_mid_m < astm_depth_high_m, "astm_depth_mid_m", astm_depth_mid_m, "<", "astm_depth_high_m",
          astm_depth_high_m);
  RequireSeverity(astm_diameter_min_m < astm_diameter_mid1_m, "astm_diameter_min_m", astm_diameter_min_m, "<",
          "astm_diameter_mid1_m", astm_diameter_mid1_m);
  RequireSeverity(astm_diameter_mid1_m < astm_diameter_mid2_m, "astm_diameter_mid1_m", astm_diameter_mid1_m, "<",
          "astm_diameter_mid2_m", astm_diameter_mid2_m);
  RequireSeverity(astm_diameter_mid2_m < astm_diameter_max_m, "astm_diameter_mid2_m", astm_diameter_mid2_m, "<",
          "astm_diameter_max_m", astm_diameter_max_m);
  RequireSeverity(astm_equivalent_area_m2 > 0, "astm_equivalent_area_m2", astm_equivalent_area_m2, ">", "0", 0);
  RequireSeverity(fhwa_pothole_low_m < fhwa_pothole_mid_m, "fhwa_pothole_low_m", fhwa_pothole_low_m, "<", "fhwa_pothole_mid_m",
          fhwa_pothole_mid_m);
  RequireSeverity(fhwa_crack_low_m < fhwa_crack_mid_m, "fhwa_crack_low_m", fhwa_crack_low_m, "<", "fhwa_crack_mid_m",
          fhwa_crack_mid_m);
  RequireSeverity(intervention_depth_m > 0, "intervention_depth_m", intervention_depth_m, ">", "0", 0);
  RequireSeverity(intervention_width_m > 0, "intervention_width_m", intervention_width_m, ">", "0", 0);
  RequireSeverity(intervention_crack_width_m > 0, "intervention_crack_width_m", intervention_crack_width_m, ">", "0", 0);
}

const OptionTable<SeverityOptions>& SeverityOptions::Table() {
  using O = SeverityOptions;
  static const auto table =
      OptionTable<O>()
          .Add("astm_depth_low_m", &O::astm_depth_low_m, "ASTM D6433 smallest graded depth", "m")
          .Above(0)
          .Add("astm_depth_mid_m", &O::astm_depth_mid_m, "ASTM D6433 depth bin edge", "m")
          .Above(0)
          .Add("astm_depth_high_m", &O::astm_depth_high_m, "ASTM D6433 depth bin edge", "m")
          .Above(0)
          .Add("astm_diameter_min_m", &O::astm_diameter_min_m, "ASTM D6433 smallest graded diameter", "m")
          .Above(0)
          .Add("astm_diameter_mid1_m", &O::astm_diameter_mid1_m, "ASTM D6433 diameter bin edge", "m")
          .Above(0)
          .Add("astm_diameter_mid2_m", &O::astm_diameter_mid2_m, "ASTM D6433 diameter bin edge", "m")
          .Above(0)
          .Add("astm_diameter_max_m", &O::astm_diameter_max_m, "ASTM D6433 largest table diameter", "m")
          .Above(0)
          .Add("astm_equivalent_area_m2", &O::astm_equivalent_area_m2, "area of one equivalent pothole", "m2")
          .Above(0)
          .Add("fhwa_pothole_min_diameter_m", &O::fhwa_pothole_min_diameter_m, "FHWA smallest pothole", "m")
          .Min(0)
          .Add("fhwa_pothole_low_m", &O::fhwa_pothole_low_m, "FHWA pothole low/moderate depth edge", "m")
          .Above(0)
          .Add("fhwa_pothole_mid_m", &O::fhwa_pothole_mid_m, "FHWA pothole moderate/high depth edge", "m")
          .Above(0)
          .Add("fhwa_crack_low_m", &O::fhwa_crack_low_m, "FHWA crack low/moderate width edge", "m")
          .Above(0)
          .Add("fhwa_crack_mid_m", &O::fhwa_crack_mid_m, "FHWA crack moderate/high width edge", "m")
          .Above(0)
          .Add("intervention_depth_m", &O::intervention_depth_m, "pothole intervention depth", "m")
          .Above(0)
          .Add("intervention_width_m", &O::intervention_width_m, "pothole intervention width", "m")
          .Above(0)
          .Add("intervention_crack_width_m", &O::intervention_crack_width_m, "crack intervention width", "m")
          .Above(0);
  return table;
}

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

InterventionGrade GradeDepressionIntervention(double max_depth_m, double max_width_m, const SeverityOptions& o) {
  InterventionGrade g;
  const bool deep = std::isfinite(max_depth_m) && max_depth_m >= o.intervention_depth_m;
  const bool wide = std::isfinite(max_width_m) && max_width_m >= o.intervention_width_m;
  g.needed = deep && wide;
  g.rule = fmt::format("depth {:.0f} mm {} {:.0f} mm and width {:.0f} mm {} {:.0f} mm", Mm(max_depth_m),
                       deep ? ">=" : "<", Mm(o.intervention_depth_m), Mm(max_width_m), wide ? ">=" : "<",
                       Mm(o.intervention_width_m));
  return g;
}

InterventionGrade GradeCrackIntervention(double max_width_m, const SeverityOptions& o) {
  InterventionGrade g;
  g.needed = std::isfinite(max_width_m) && max_width_m >= o.intervention_crack_width_m;
  g.rule = fmt::format("crack max width {:.1f} mm {} {:.0f} mm", Mm(max_width_m), g.needed ? ">=" : "<",
                       Mm(o.intervention_crack_width_m));
  return g;
}

}  // namespace rs
