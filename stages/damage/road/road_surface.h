#pragma once
// Road surface model in 3D for one frame: the dominant plane (RANSAC) after
// which points far above it (vehicles, people, kerbs) are removed as obstacles,
// then a Tukey-robust quadratic height field over that plane, refitted on the
// largest smooth region when a surface cut off by a step or an obstacle (the
// pavement beyond a parked car) took part. Damage lies below the surface and is
// rejected by the robust weights, not fitted.

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace rs {

/// Quadratic road surface in the camera frame (x right, y down, z forward).
/// Plane frame: origin o, in-plane axes e1, e2, unit normal n pointing to the
/// camera side ("up"). Height above the plane h = n·(P − o); road height
/// q(s, t) = c0 + c1 s + c2 t + c3 s² + c4 s t + c5 t², with s = e1·(P − o) / L,
/// t = e2·(P − o) / L (L normalises the fit).
struct RoadSurface {
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d e1 = Eigen::Vector3d::UnitX(), e2 = Eigen::Vector3d::UnitZ(), normal = -Eigen::Vector3d::UnitY();
  double scale_m = 1;  ///< L
  Eigen::Matrix<double, 6, 1> coeffs = Eigen::Matrix<double, 6, 1>::Zero();
  double residual_sigma_m = 0;  ///< robust σ of road residuals
  double camera_height_m = 0;   ///< distance of the camera centre from the plane
  int points_used = 0;          ///< 3D samples in the fit
  int inliers = 0;              ///< samples with non-zero final weight
  int obstacle_points = 0;      ///< samples removed as obstacles

  /// Road height q at plane coordinates of P, minus P's height: > 0 below the road.
  double DepthBelow(const Eigen::Vector3d& p_cam) const;
  /// Depth Z (camera z) where the pixel ray (u, v) meets the surface; NaN if it misses.
  double RayDepth(const RectifiedStereo& g, double u, double v) const;
};

/// Camera-frame point (m) on the ray of pixel (u, v) at depth z (camera z, m).
inline Eigen::Vector3d CameraPointAtDepth(const RectifiedStereo& g, double u, double v, double z) {
  return {(u - g.cx_px) * z / g.f_px, (v - g.cy_px) * z / g.f_px, z};
}

/// Camera-frame point (m) of pixel (u, v) with disparity d (px): Z = f·B / d.
inline Eigen::Vector3d CameraPointFromDisparity(const RectifiedStereo& g, double u, double v, double d) {
  return CameraPointAtDepth(g, u, v, g.f_px * g.baseline_m / d);
}

/// Fits the road surface to a disparity map (CV_32F, px; ≤ 0 or NaN invalid).
/// Throws std::invalid_argument on bad geometry or too few valid disparities.
RoadSurface FitRoadSurface(const cv::Mat& disparity_px, const RectifiedStereo& geometry,
                           const RoadModelOptions& options);

/// Per-pixel products of the road model.
struct RoadRelief {
  cv::Mat transformed_disparity_px;  ///< CV_32F: d − d_road + δ; 0 where invalid (as fan2019's disp_tg)
  cv::Mat depth_below_mm;            ///< CV_32F: depth below the road surface, mm; NaN invalid
  cv::Mat road_depth_m;              ///< CV_32F: camera Z of the road surface along each pixel ray; NaN off-road
  cv::Mat obstacle_mask;             ///< CV_8U: 255 where the point is an obstacle above the road
  cv::Mat valid_mask;                ///< CV_8U: 255 where the disparity is valid
  /// CV_32F: local correction (mm, > 0 = road below the quadratic) already applied to the
  /// products above: true road height = quadratic − correction (zeros when off).
  cv::Mat correction_mm;
  cv::Mat correction_grid_mm;  ///< CV_32F per-cell correction (mm) behind correction_mm (empty when off)
  /// Robust σ of the transformed disparity about its box-smoothed value (px), measured by
  /// FinishRoadRelief and reused by RefineRoadRelief (0 = not smoothed).
  double smooth_noise_px = 0;
};

/// Evaluates the model on every pixel, then (local_cell_px > 0) corrects it locally: per cell,
/// the median depth below the model of road pixels within a band (4 σ below the model and up to
/// the obstacle height above it: a rise off the quadratic is road, damage lies below; damage and
/// obstacles excluded; twice, the second band ±3× the first pass' spread), empty cells filled from
/// their neighbours, 3×3 smoothed, bilinearly interpolated.
/// `exclude` (optional CV_8U, non-zero = known damage) is left out of the local correction.
RoadRelief ComputeRoadRelief(const cv::Mat& disparity_px, const RectifiedStereo& geometry, const RoadSurface& surface,
                             const RoadModelOptions& options, const cv::Mat& exclude = cv::Mat());

/// ComputeRoadRelief in two steps, so a second pass with other `exclude` (DetectDamage's
/// recomputation without the found depressions) reuses the per-pixel evaluation:
/// EvaluateRoadModel = the quadratic on every pixel (no local correction, no smoothing;
/// correction_mm left empty);
/// FinishRoadRelief = local correction and smoothing applied to it (`evaluated` unchanged; the
/// result shares its masks).
RoadRelief EvaluateRoadModel(const cv::Mat& disparity_px, const RectifiedStereo& geometry, const RoadSurface& surface,
                             const RoadModelOptions& options);
RoadRelief FinishRoadRelief(const RoadRelief& evaluated, const cv::Mat& disparity_px, const RectifiedStereo& geometry,
                            const RoadSurface& surface, const RoadModelOptions& options,
                            const cv::Mat& exclude = cv::Mat());

/// Recomputes the local correction of a FinishRoadRelief result with `exclude` left out, from
/// `evaluated` (the untouched EvaluateRoadModel result it was made from), updating only the
/// regions whose correction changed: the same result as ComputeRoadRelief(..., exclude).
void RefineRoadRelief(RoadRelief& relief, const RoadRelief& evaluated, const cv::Mat& disparity_px,
                      const RectifiedStereo& geometry, const RoadSurface& surface, const RoadModelOptions& options,
                      const cv::Mat& exclude);

}  // namespace rs
