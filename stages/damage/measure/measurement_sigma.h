#pragma once
// Stated uncertainty of a depression's area and volume (every figure comes with the uncertainty
// it is within; σ_Z covers the depth). The outline lies where the relief crosses the rim
// threshold: its position is uncertain by the matcher's spread of the wall (a toe beside it, a
// shallower floor beside it: docs/stages/disparity.md "Pothole walls") and, where the depression
// is shallow against the stereo noise, by where that noise makes the wall cross the threshold.

#include "stages/damage/damage_options.h"

#include <opencv2/core.hpp>

#include <cstdint>

namespace rs {

/// Share of an outline's length (px) that its boundary pixels (pixels of the region with a
/// 4-neighbour outside) count, averaged over edge directions: an edge at angle θ to the rows
/// has max(|cos θ|, |sin θ|) of them per pixel of length, whose mean is 2√2/π.
inline constexpr double kBoundaryPixelsPerOutlinePx = 0.9003163161571061;

/// Whether pixel (u, v) of a CV_16U label image is on its region's boundary: a 4-neighbour
/// carries another label, or the pixel is on the image border.
inline bool IsBoundaryPixel(const cv::Mat& labels, int u, int v) {
  if (u == 0 || v == 0 || u + 1 == labels.cols || v + 1 == labels.rows) return true;
  const uint16_t* l = labels.ptr<uint16_t>(v);
  const uint16_t id = l[u];
  return l[u - 1] != id || l[u + 1] != id || labels.ptr<uint16_t>(v - 1)[u] != id ||
         labels.ptr<uint16_t>(v + 1)[u] != id;
}

/// Outline position uncertainty, px: outline_sigma_px + outline_blur_px · σ_Z / max depth
/// (the ratio capped at 2, and 2 where the depth is unknown or not below the road).
double OutlineSigmaPx(double max_depth_m, double sigma_depth_m, const MeasureOptions& o);

/// σ of the area, m²: the outline moved by `outline_sigma_px` along its whole length.
/// `boundary_area_m2`: the summed road-plane area of the region's boundary pixels.
double AreaSigmaM2(double boundary_area_m2, double outline_sigma_px);

/// σ of the volume, m³: the depth noise averaged over the region (σ_Z over the independent
/// patches of depth_noise_correlation_px² pixels among `pixels`), and the volume the outline's
/// uncertainty moves (σ_area at the mean depth), in quadrature.
double VolumeSigmaM3(double area_m2, double mean_depth_m, double sigma_depth_m, double sigma_area_m2, int pixels,
                     const MeasureOptions& o);

}  // namespace rs
