#include "formats/altitude_reference.h"

namespace rs {

const char* ToString(AltitudeReference r) {
  switch (r) {
    case AltitudeReference::kUnknown: return "unknown";
    case AltitudeReference::kEllipsoid: return "ellipsoid";
    case AltitudeReference::kAmsl: return "amsl";
    case AltitudeReference::kTakeoff: return "takeoff";
  }
  return "unknown";
}

}  // namespace rs
