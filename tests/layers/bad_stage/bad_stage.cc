// Fixture of the layer test (tests/CMakeLists.txt): a stage source that includes the simulator,
// an evaluator and another stage. Never compiled; the configure step must refuse it.
#include "eval/damage/damage_eval.h"
#include "sim/simulate.h"
#include "stages/damage/damage_types.h"
