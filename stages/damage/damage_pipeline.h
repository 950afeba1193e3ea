#pragma once
// Library entry points: full per-frame damage detection from a true disparity
// map, and segmentation of a foreign transformed disparity image (the
// `roadsurvey segment` command). The job-graph stage glue calls these.

#include "stages/damage/damage_options.h"
#include "stages/damage/damage_types.h"
#include "stages/damage/road/road_surface.h"
#include "stages/damage/segment/segmentation.h"

#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <string_view>
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

/// Wall time of one pass of DetectDamage.
struct PassTime {
  std::string name;  ///< as in DamagePassNames()
  double ms = 0;
};

/// Per-frame result.
struct FrameDamage {
  RoadSurface surface;
  RoadRelief relief;
  cv::Mat labels;                         ///< CV_16U: depressions 1..k, then cracks k+1..n
  /// CV_8U, 255 on the road as the frame analysed it (damage included): valid disparity within the
  /// analysed range, not an obstacle, not an island of mismatches cut off from the road.
  cv::Mat road_mask;
  std::vector<DamageInstance> instances;  ///< graded, ids match `labels`
  double threshold_sigma = 0;             ///< segmentation threshold, σ below the road
  double analysed_range_m = 0;            ///< farthest camera depth analysed (AnalysedRangeM), m
  std::vector<PassTime> pass_ms;          ///< wall time of each pass run, in order (skipped passes absent)
  /// Wall time of the pass `name`, 0 when it did not run.
  double PassMs(std::string_view name) const;
};

/// The passes of DetectDamage, in the order they run (a pass may be skipped by the options or
/// the frame): "paint edges", "range limit", "road fit", "relief", "road mask", "noise map",
/// "segmentation", "obstacle removal", "road refinement", "rim", "pothole noise",
/// "measurement", "floor visibility", "cracks", "grading".
std::vector<std::string> DamagePassNames();

/// Farthest camera depth analysed: where σ_Z(Z) = Z²·σ_d/(f·B) reaches road.max_depth_sigma_m
/// (infinite when 0), but at least road.min_range_factor × `nearest_depth_m` (the frame's
/// nearest road depth; 0 = unknown).
double AnalysedRangeM(const RectifiedStereo& geometry, const DamageOptions& options, double nearest_depth_m = 0);

/// Nearest road depth of a frame: the depth at the 98th-percentile disparity (robust to a few
/// wrong large disparities), from a 4-pixel grid of valid pixels; 0 when none is valid.
double NearestDepthM(const cv::Mat& disparity_px, const RectifiedStereo& geometry);

/// Road model, transformed disparity, depressions (measured on the road model) and, when
/// `left_image` is given, cracks; every instance graded. `disparity_px`: CV_32F, ≤ 0 invalid;
/// disparities beyond AnalysedRangeM are ignored. `sharp_disparity_px` (optional, CV_32F of the
/// same size): the disparity stage's second image (its small refinement window alone), on which
/// the volumes are summed (sharp_disparity.h); empty = the one image throughout.
/// `options` must have passed DamageOptions::Check() (the caller checks once, not per frame).
/// Throws std::invalid_argument on bad inputs.
FrameDamage DetectDamage(const cv::Mat& disparity_px, const cv::Mat& left_image, const RectifiedStereo& geometry,
                         const DamageOptions& options, const cv::Mat& sharp_disparity_px = cv::Mat());

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
/// Checks `options` (std::invalid_argument or OptionError).
TransformedSegmentation SegmentTransformedDisparity(const cv::Mat& transformed, const cv::Mat& left_image,
                                                    const DamageOptions& options,
                                                    std::optional<ReliefScale> scale = std::nullopt);

}  // namespace rs
