#pragma once
// Metric measurement of segmented depressions on the road model: area on the
// road plane, depth, volume, diameters, outline in camera metres, σ_Z.

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"
#include "stages/damage/road/road_surface.h"

#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// Road-plane area of each pixel, m² (CV_32F; NaN off-road): a pixel ray meeting the
/// plane at camera depth Z covers Z³ / (f² · h), h = camera height above the plane.
cv::Mat PixelAreaOnRoad(const RoadRelief& relief, const RectifiedStereo& geometry, const RoadSurface& surface);

/// Sets each instance of `labels` (in place) to the part of the road it lowers, as the depth
/// shows it: the threshold of the unsupervised segmentation stops short of the shallow rim, and
/// its superpixels straddle it. Per instance, within a band of 30 % of its equivalent radius,
/// distances measured on the road (`row_elongation`, per row: road length of a pixel along the
/// column / across it, RoadRowElongation; empty = square pixels): the road level is a plane fitted
/// (robustly) to the depth of the ring between one and two bands outside (the local road-model
/// misfit; its residual σ is the stereo noise); the rim threshold above that plane is the largest
/// of `rim_depth_m`, `rim_depth_fraction` × the instance's depth (99th percentile) and 3 σ.
/// Outer pixels of the instance shallower than it (connected to the outside through such
/// pixels) are dropped, connected pixels deeper than it join. With `ring_window_px` > 0 (the
/// relief's smoothing window), whole one-pixel rings outside that then join while their mean
/// depth above the plane exceeds 2 σ of a mean (σ·w/√n) and the first two terms (the wall's
/// shallow outer part, below the per-pixel noise). `raw_depth_below_mm` (optional, CV_32F): the
/// unsmoothed depth below the quadratic road model (EvaluateRoadModel's), on which the rim is
/// found (the relief's correction_mm applied here; its per-pixel noise measured on the ring):
/// the relief's smoothing spreads a wall's depth beyond the rim. Last, the outline is extended to
/// where the wall meets the road: the ring means inside and outside fitted by
/// c + a·max(0, x + gap)^p, p in [1, 2] (a sharp or a tangential edge); first order (the two
/// inner rings' slope) where the per-pixel noise sets the threshold (there the profile is the
/// stereo matcher's blur). In oblique views (e >= 1.5) per side along image scanlines: the far
/// side along columns, the lateral sides along rows, the near side only where its edge is no
/// occluding one (the edge pixel within the wall's outer quarter); nothing where the matcher's
/// noise (ring differences one smoothing window apart) sets the threshold.
void ExtendToRim(cv::Mat& labels, const RoadRelief& relief, double rim_depth_m, double rim_depth_fraction = 0,
                 int ring_window_px = 0, const std::vector<double>& row_elongation = {},
                 const cv::Mat& raw_depth_below_mm = cv::Mat());

/// Measures every instance 1..max of a CV_16U label image. Invalid pixels inside an
/// instance count for area and take the instance's mean depth for the volume.
/// Type: pothole when max depth ≥ pothole_min_depth_m and ≥ pothole_min_depth_sigma · σ_Z, equivalent diameter ≥
/// pothole_min_diameter_m, area ≥ pothole_min_compactness · π/4 · max diameter² and the
/// half-max-depth core at least pothole_min_core_width_m wide (CoreWidthM), otherwise other. Severity is not graded
/// here. `noise_px` (optional CV_32F, the road's local disparity noise σ in px, e.g. LocalReliefNoise of the
/// transformed disparity): a pothole's max depth must also reach pothole_min_noise_sigma times its mean over the
/// instance as depth below the surface (σ·Z²/(f·B)·|n·ray|), or, failing that, at the depression's own scale
/// (MeasureScaleNoise over a window as wide as the square inscribed in its core, at least kMinScaleWindowPx): its
/// deepest window mean pothole_min_noise_sigma times the road's window-mean σ around it and (pothole_min_spike_ratio >
/// 0) that ratio times their spike_quantile above the road. `volume_depth_below_mm` (optional, CV_32F, NaN invalid):
/// the depth the volume sums instead of the relief's (the disparity stage's sharp image, SharpDepthBelowMm: the smooth
/// refinement window makes the floor beside a wall shallower and spreads the wall beyond the outline); where it is NaN
/// the relief's depth is summed.
std::vector<DamageInstance> MeasureDepressions(const cv::Mat& labels, const RoadRelief& relief,
                                               const RectifiedStereo& geometry, const RoadSurface& surface,
                                               const MeasureOptions& options, const cv::Mat& noise_px = cv::Mat(),
                                               const cv::Mat& volume_depth_below_mm = cv::Mat());

/// Width (m) of the largest circle inscribed in the part of instance `id` at least
/// `min_depth_m` below the road (pixel widths from `pixel_area_m2`); 0 when empty.
/// `width_px` (optional): the same circle's width in pixels.
double CoreWidthM(const cv::Mat& labels, int id, const RoadRelief& relief, const cv::Mat& pixel_area_m2,
                  double min_depth_m, cv::Rect box = cv::Rect(),  ///< box: the label's bounding box (empty = search)
                  double* width_px = nullptr);

/// Outer boundary of one label as a polygon (pixel coordinates), simplified to 1 px.
std::vector<cv::Point> OutlineOf(const cv::Mat& labels, int id);
/// The same, searching only `box` (the label's bounding box, e.g. from LabelBoxes): per-instance
/// work stays proportional to the instance, not the frame.
std::vector<cv::Point> OutlineOf(const cv::Mat& labels, int id, const cv::Rect& box);

/// Bounding box of every label 0..max of a CV_16U label image in one pass (index = id;
/// empty cv::Rect for absent ids; entry 0 is the background's box and unused).
std::vector<cv::Rect> LabelBoxes(const cv::Mat& labels);

/// Stereo depth uncertainty σ_Z = Z²·σ_d / (f·B), m.
double StereoDepthSigma(double z_m, double sigma_disparity_px, const RectifiedStereo& geometry);

}  // namespace rs
