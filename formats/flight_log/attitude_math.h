#pragma once
// Euler angles as logs write them -> the track's body(FRD)-to-NED quaternion.

#include <cstdint>

#include "formats/flight_log/flight_track.h"

namespace rs::flightlog {

/// Aerospace (ZYX) Euler angles in degrees -> AttitudeSample:
/// R_ned_body = Rz(yaw) * Ry(pitch) * Rx(roll).
AttitudeSample AttitudeFromEulerDeg(int64_t t_ns, double roll_deg, double pitch_deg, double yaw_deg);

}  // namespace rs::flightlog
