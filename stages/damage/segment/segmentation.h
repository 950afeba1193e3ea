#pragma once
// Unsupervised segmentation of depressions (potholes, sunken patches) in a
// transformed disparity image, where undamaged road sits at one level and
// damage lies below it. Works on calibrated output of ComputeRoadRelief and on
// foreign 8/16-bit or float images of unknown scale (fan2019's disp_tg).

#include "stages/damage/damage_options.h"

#include <opencv2/core.hpp>

#include <optional>
#include <vector>

namespace rs {

/// A single-channel relief image as float values plus a validity mask.
struct ReliefImage {
  cv::Mat value;  ///< CV_32F, in the input's units
  cv::Mat valid;  ///< CV_8U, 255 where the input holds a measurement
  /// Optional, per row: road length of a pixel along the column / across it (RoadRowElongation);
  /// with SegmentOptions::slic_ground, superpixels are shaped square on the road. Empty = 1.
  std::vector<double> row_elongation;
};

/// Fills the holes of a CV_8U mask (0 / 255): background components not connected to the border.
void FillHoles(cv::Mat& mask);

/// Converts an 8/16-bit or float single-channel image. Integer 0 and float
/// ≤ 0 / NaN / inf mean "no measurement" (the convention of disp_tg and of
/// ComputeRoadRelief). Throws std::invalid_argument for other types/channels.
ReliefImage ToRelief(const cv::Mat& image);

/// Road level and noise of a relief image: value = level + sigma·z.
struct ReliefScale {
  double road_level = 0;  ///< the dominant mode of the valid values (undamaged road)
  double sigma = 1;       ///< robust spread of the road around its level
};

/// Estimates the road level as the histogram mode and σ from the upper half
/// of the road distribution (damage only populates the lower tail).
/// Throws std::invalid_argument when fewer than 100 pixels are valid.
ReliefScale EstimateReliefScale(const ReliefImage& relief);

/// Result of SegmentDepressions.
struct DepressionSegmentation {
  cv::Mat labels;  ///< CV_16U instance ids 1..count, 0 = road / unknown
  int count = 0;
  ReliefScale scale;           ///< level and σ used
  double threshold_sigma = 0;  ///< chosen threshold, σ below the road level (positive)
  int dropped_small = 0;       ///< components removed by the minimum size
  int dropped_gentle = 0;      ///< instances removed for a wall no steeper than the road (wall_test.h)
  cv::Mat noise_sigma;         ///< CV_32F per-pixel σ the seeds were tested against (the caller's map; may be empty)
};

/// Energy-minimising threshold on normalised relief z = (value − level)/σ: the
/// split of the valid pixels into two classes (damage below, road above) with
/// the least within-class squared error (Otsu's criterion; the road's heavy
/// lower tail, common in real disparity, defeats Gaussian-mixture criteria).
/// Clamped to [min_threshold_sigma, max_threshold_sigma]; returned as a
/// positive number of σ below the road level.
double EnergyThresholdSigma(const cv::Mat& z, const cv::Mat& valid, const SegmentOptions& options);

/// Segments depressions. `scale` overrides the robust estimate when given.
/// `pixel_area_m2` (CV_32F, road-plane area of each pixel) enables the metric
/// minimum size; empty = use options.min_area_px. `noise_sigma` (CV_32F, per-pixel σ in the
/// relief's units, e.g. LocalReliefNoise): a seed must also lie min_threshold_sigma of it below
/// the road (significant against the noise where it lies), and any pixel options.seed_noise_sigma
/// of it below the road seeds whatever the frame's threshold; growth keeps the frame's threshold,
/// except on `noisy_class` (optional CV_8U, non-zero = pixels of their own, noisier class, e.g.
/// within the margin of paint edges, StrongEdgeMask), which join a region only as deep as a seed
/// (a region would grow along a paint line's wrong winners). Throws std::invalid_argument on bad types or sizes
/// (noisy_class without noise_sigma included).
DepressionSegmentation SegmentDepressions(const ReliefImage& relief, const SegmentOptions& options,
                                          const cv::Mat& pixel_area_m2 = cv::Mat(),
                                          std::optional<ReliefScale> scale = std::nullopt,
                                          const cv::Mat& noise_sigma = cv::Mat(),
                                          const cv::Mat& noisy_class = cv::Mat());

}  // namespace rs
