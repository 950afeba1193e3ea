#pragma once
// Test support for the flight-log writers' round trips: a known attitude history
// (roll and pitch oscillate, yaw turns through 360° several times).

#include <cmath>
#include <cstdint>

#include "formats/flight_log/flight_track.h"

namespace rs::test {

/// Roll, pitch, yaw (ZYX Euler angles, radians) `t_s` seconds into the test flight.
inline void TruthEulerRad(double t_s, double* r, double* p, double* y) {
  constexpr double kPi = 3.14159265358979323846;
  *r = 20 * kPi / 180 * std::sin(0.3 * t_s);
  *p = 10 * kPi / 180 * std::cos(0.2 * t_s);
  *y = std::fmod(37 * kPi / 180 * t_s, 2 * kPi);
}

/// The same attitude as a unit quaternion sample stamped `t_ns`.
inline AttitudeSample TruthAttitudeAt(int64_t t_ns, double t_s) {
  double r, p, y;
  TruthEulerRad(t_s, &r, &p, &y);
  const double cr = std::cos(r / 2), sr = std::sin(r / 2), cp = std::cos(p / 2), sp = std::sin(p / 2);
  const double cy = std::cos(y / 2), sy = std::sin(y / 2);
  return {t_ns, cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
          cr * cp * sy - sr * sp * cy};
}

}  // namespace rs::test
