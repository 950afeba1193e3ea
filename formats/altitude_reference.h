#pragma once
// The altitude datum and the "not given" value, shared by flight tracks
// (formats/flight_log) and frame priors; kept in rs_formats so frame priors do
// not depend on the flight-log readers. Conventions: docs/conventions.md.

#include <limits>

namespace rs {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// What an altitude is measured from. Confusing these is the classic
/// georeferencing error, so every fix says which one it carries.
enum class AltitudeReference {
  kUnknown,
  kEllipsoid,  ///< height above the WGS84 ellipsoid
  kAmsl,       ///< above mean sea level (geoid, e.g. EGM96/EGM2008)
  kTakeoff,    ///< relative to the take-off/home point
};
const char* ToString(AltitudeReference r);

}  // namespace rs
