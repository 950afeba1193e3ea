#pragma once
// Severity of one frame's damage instance, graded by the shared rules (survey/grading/severity_rules.h).

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"

namespace rs {

/// Fills astm, fhwa, intervention and intervention_rule of one instance from its type and
/// measurements (average diameter = equivalent diameter; width = maximum diameter).
void GradeInstance(DamageInstance& instance, const SeverityOptions& options);

}  // namespace rs
