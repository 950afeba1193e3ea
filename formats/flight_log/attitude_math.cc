#include "formats/flight_log/attitude_math.h"

#include <cmath>

namespace rs::flightlog {

AttitudeSample AttitudeFromEulerDeg(int64_t t_ns, double roll_deg, double pitch_deg, double yaw_deg) {
  const double d2r = M_PI / 180.0;
  const double cr = std::cos(roll_deg * d2r / 2), sr = std::sin(roll_deg * d2r / 2);
  const double cp = std::cos(pitch_deg * d2r / 2), sp = std::sin(pitch_deg * d2r / 2);
  const double cy = std::cos(yaw_deg * d2r / 2), sy = std::sin(yaw_deg * d2r / 2);
  AttitudeSample a;
  a.t_ns = t_ns;
  a.qw = cy * cp * cr + sy * sp * sr;
  a.qx = cy * cp * sr - sy * sp * cr;
  a.qy = cy * sp * cr + sy * cp * sr;
  a.qz = sy * cp * cr - cy * sp * sr;
  return a;
}

}  // namespace rs::flightlog
