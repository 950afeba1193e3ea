#pragma once
// Library entry points: full per-frame damage detection from a true disparity
// map, and segmentation of a foreign transformed disparity image (the
// `roadsurvey segment` command). The job-graph stage glue calls these.

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"
#include "stages/damage/road_surface.h"
#include "stages/damage/segmentation.h"

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

namespace rs {

/// All options of the damage algorithms.
struct DamageOptions {
  RoadModelOptions road;
  SegmentOptions segment;
  CrackOptions crack;
  MeasureOptions measure;
  SeverityOptions severity;
  void Check() const;
};

/// Per-frame result.
struct FrameDamage {
  RoadSurface surface;
  RoadRelief relief;
  cv::Mat labels;                         ///< CV_16U: depressions 1..k, then cracks k+1..n
  std::vector<DamageInstance> instances;  ///< graded, ids match `labels`
  double threshold_sigma = 0;             ///< segmentation threshold, σ below the road
  double ms_road = 0, ms_segment = 0, ms_cracks = 0, ms_measure = 0;  ///< timings
};

/// Road model, transformed disparity, depressions (measured on the road model) and, when
/// `left_image` is given, cracks; every instance graded. `disparity_px`: CV_32F, ≤ 0 invalid.
/// Throws std::invalid_argument on bad inputs or options.
FrameDamage DetectDamage(const cv::Mat& disparity_px, const cv::Mat& left_image, const StereoGeometry& geometry,
                         const DamageOptions& options);

/// Segmentation of an 8/16-bit or float transformed-disparity image with unknown scale
/// (road level and σ estimated robustly unless `scale` is given). Instances carry pixel
/// counts and outlines; metric fields stay NaN (the road disparity is not recoverable from
/// a transformed image). With `left_image`, cracks are added (lengths in px only).
struct TransformedSegmentation {
  cv::Mat labels;  ///< CV_16U instance ids
  std::vector<DamageInstance> instances;
  ReliefScale scale;
  double threshold_sigma = 0;
};
TransformedSegmentation SegmentTransformedDisparity(const cv::Mat& transformed, const cv::Mat& left_image,
                                                    const DamageOptions& options,
                                                    std::optional<ReliefScale> scale = std::nullopt);

/// A synthetic stereo frame with known truth: camera `height_m` above a plane, pitched
/// `pitch_deg` below the horizon, one spherical-cap pothole (depth, radius) at camera depth
/// `pothole_z_m` on the optical axis' column, optionally a raised slab (obstacle) of height
/// `box_height_m` to the right; disparity noise `sigma_d_px` (seeded).
struct SyntheticRoadScene {
  int width = 1280, height = 720;
  StereoGeometry geometry{1000.0, 640.0, 360.0, 0.20};
  double height_m = 1.5, pitch_deg = 45.0;
  double pothole_depth_m = 0.06, pothole_radius_m = 0.25, pothole_z_m = 2.2;
  double box_height_m = 0;  ///< 0 = no obstacle
  double sigma_d_px = 0.05;
  unsigned seed = 3;
  /// Disparity map (CV_32F) of the scene.
  cv::Mat Render() const;
  /// Truth of the pothole: area π a², depth h, volume π h² (3R − h) / 3.
  double TrueAreaM2() const;
  double TrueVolumeM3() const;
};

/// Timing of DetectDamage on a synthetic frame (no image, so no cracks), medians over runs.
struct DamageBench {
  double wall_ms = 0;  ///< elapsed time (inflated when other processes share the cores)
  double cpu_ms = 0;   ///< process CPU time summed over threads: the single-core wall time bound
};
/// Runs DetectDamage `repeats` times on a width × height synthetic frame.
DamageBench BenchDetectDamage(int width, int height, int repeats);

}  // namespace rs
