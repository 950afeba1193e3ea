#include "formats/flight_log/flight_track.h"

#include <algorithm>

namespace rs {

const char* ToString(TimeBase b) { return b == TimeBase::kUtc ? "utc" : "boot"; }

std::optional<AttitudeSample> AttitudeAt(const std::vector<AttitudeSample>& att, int64_t t_ns) {
  const auto it =
      std::lower_bound(att.begin(), att.end(), t_ns, [](const AttitudeSample& a, int64_t t) { return a.t_ns < t; });
  if (it == att.end()) return std::nullopt;
  if (it->t_ns == t_ns) return *it;
  if (it == att.begin()) return std::nullopt;
  const AttitudeSample &a = *(it - 1), &b = *it;
  const double u = static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  // q and -q are the same rotation: interpolate towards the nearer sign.
  const double s = a.qw * b.qw + a.qx * b.qx + a.qy * b.qy + a.qz * b.qz < 0 ? -u : u;
  AttitudeSample q{t_ns, (1 - u) * a.qw + s * b.qw, (1 - u) * a.qx + s * b.qx, (1 - u) * a.qy + s * b.qy,
                   (1 - u) * a.qz + s * b.qz};
  const double n = std::sqrt(q.qw * q.qw + q.qx * q.qx + q.qy * q.qy + q.qz * q.qz);
  q.qw /= n, q.qx /= n, q.qy /= n, q.qz /= n;
  return q;
}

}  // namespace rs
