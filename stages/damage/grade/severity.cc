#include "stages/damage/grade/severity.h"

namespace rs {

void GradeInstance(DamageInstance& d, const SeverityOptions& o) {
  d.astm = {};
  d.fhwa = {};
  InterventionGrade intervention;
  if (d.type == DamageType::kCrack) {
    d.fhwa = GradeFhwaCrack(d.mean_width_m, o);
    intervention = GradeCrackIntervention(d.max_width_m, o);
  } else {
    if (d.type == DamageType::kPothole) {
      d.astm = GradeAstmPothole(d.max_depth_m, d.equivalent_diameter_m, d.area_m2, o);
      d.fhwa = GradeFhwaPothole(d.max_depth_m, d.equivalent_diameter_m, o);
    } else {
      d.astm.rule = "ASTM D6433: not a pothole (type other)";
      d.fhwa.rule = "FHWA LTPP: not a pothole (type other)";
    }
    intervention = GradeDepressionIntervention(d.max_depth_m, d.max_diameter_m, o);
  }
  d.intervention = intervention.needed;
  d.intervention_rule = std::move(intervention.rule);
}

}  // namespace rs
