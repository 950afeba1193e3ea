#pragma once
// Area coverage of a pixel's footprint by a painted strip: a camera pixel
// integrates light over its footprint, so a pixel straddling a paint edge
// records a mix weighted by the fraction of the footprint on the paint, not
// the colour at its centre (a hard edge would match at whole disparities).

#include <algorithm>
#include <utility>

namespace rs::sim {

/// P(X <= x) for X = U_a + U_b, U_w uniform on [-w/2, w/2]: the fraction of a
/// box footprint whose projection on an axis lies at or below x from its
/// centre, where a and b are the projected lengths of the box's two sides
/// (|side_1 . axis|, |side_2 . axis|). The projected density is a trapezoid.
inline double BoxProjectionCdf(double x, double a, double b) {
  if (a < b) std::swap(a, b);
  a = std::max(a, 1e-12);  // a point footprint: a step at 0
  const double y = x + 0.5 * (a + b);
  if (y <= 0) return 0;
  if (y >= a + b) return 1;
  if (y < b) return y * y / (2 * a * b);
  if (y <= a) return (y - 0.5 * b) / a;
  const double z = a + b - y;
  return 1 - z * z / (2 * a * b);
}

/// Fraction of a footprint centred at x (projected side lengths a, b on the
/// axis) inside the strip lo <= x' <= hi. Its integral over x is hi - lo: a
/// row of pixels across a line records the painted width exactly.
inline double StripCoverage(double x, double lo, double hi, double a, double b) {
  return BoxProjectionCdf(hi - x, a, b) - BoxProjectionCdf(lo - x, a, b);
}

}  // namespace rs::sim
