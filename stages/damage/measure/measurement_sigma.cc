#include "stages/damage/measure/measurement_sigma.h"

#include <algorithm>
#include <cmath>

namespace rs {

double OutlineSigmaPx(double max_depth_m, double sigma_depth_m, const MeasureOptions& o) {
  // Capped: at σ_Z/depth = 2 the depression is within the noise and the outline is anybody's
  // guess; the cap keeps a near-zero depth from stating an infinite area uncertainty.
  constexpr double kMaxNoiseRatio = 2.0;
  const double ratio = max_depth_m > 0 && std::isfinite(sigma_depth_m)
                           ? std::min(kMaxNoiseRatio, sigma_depth_m / max_depth_m)
                           : kMaxNoiseRatio;
  return o.outline_sigma_px + o.outline_blur_px * ratio;
}

double AreaSigmaM2(double boundary_area_m2, double outline_sigma_px) {
  return outline_sigma_px * boundary_area_m2 / kBoundaryPixelsPerOutlinePx;
}

double VolumeSigmaM3(double area_m2, double mean_depth_m, double sigma_depth_m, double sigma_area_m2, int pixels,
                     const MeasureOptions& o) {
  if (!std::isfinite(mean_depth_m) || !std::isfinite(sigma_depth_m) || pixels <= 0) return std::nan("");
  const double patch = o.depth_noise_correlation_px * o.depth_noise_correlation_px;
  const double independent = std::max(1.0, pixels / patch);
  const double noise = sigma_depth_m * area_m2 / std::sqrt(independent);
  const double outline = std::max(0.0, mean_depth_m) * sigma_area_m2;
  return std::hypot(noise, outline);
}

}  // namespace rs
