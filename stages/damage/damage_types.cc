#include "stages/damage/damage_types.h"

namespace rs {

const char* DamageTypeName(DamageType type) {
  switch (type) {
    case DamageType::kPothole: return "pothole";
    case DamageType::kCrack: return "crack";
    case DamageType::kOther: return "other";
  }
  return "other";
}

}  // namespace rs
