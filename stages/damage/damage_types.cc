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

const char* SeverityLevelName(SeverityLevel level) {
  switch (level) {
    case SeverityLevel::kNone: return "none";
    case SeverityLevel::kLow: return "low";
    case SeverityLevel::kMedium: return "medium";
    case SeverityLevel::kHigh: return "high";
  }
  return "none";
}

}  // namespace rs
