#pragma once
// The calibration-free segmentation (`roadsurvey segment`, SegmentTransformedDisparity) on a
// `roadsurvey simulate` folder: per frame our disparity's transformed image is segmented as a
// foreign one would be (no calibration, no left image) and its pixels are scored against the
// simulator's pothole masks. The simulator sets the segmentation's constants, so that real
// labelled frames (fan2019 dataset3) stay held out.

#include "eval/damage/damage_eval.h"
#include "stages/damage/damage_pipeline.h"
#include "stages/disparity/disparity.h"

#include <filesystem>
#include <string>
#include <vector>

namespace rs {

struct SimSegmentEvalOptions {
  DisparityParams disparity;  ///< the disparity stage's defaults (focal from the calibration)
  DamageOptions damage;       ///< the segmentation's options; cracks are not looked for
  int frame_step = 1;         ///< every n-th frame
  int max_frames = 0;         ///< 0 = all
  /// Frames with no truth pothole pixel in the scored range are skipped (a transformed
  /// disparity without damage is scored by its false positives elsewhere: `false_frames`).
  bool potholes_only = true;
  /// Non-empty: every evaluated frame's left image with the instances (magenta) and the truth
  /// potholes (green) outlined, as <frame>.png.
  std::filesystem::path debug_dir;
};

struct SimSegmentFrame {
  std::string frame;
  PixelMetrics pixels;
  int instances = 0;
};

struct SimSegmentEvaluation {
  int frames = 0;              ///< frames segmented
  int frames_scored = 0;       ///< of those, with truth pothole pixels in range
  int false_frames = 0;        ///< frames without a pothole in range that got an instance
  std::vector<std::string> false_frame_names;
  PixelMetrics pixels;         ///< pooled over the scored frames
  std::vector<SimSegmentFrame> per_frame;
  /// "frame id: depth, diameter, pixels, share found" of each truth pothole with ≥ 200 scored
  /// pixels in a frame: at least half of its pixels found, or not.
  std::vector<std::string> potholes_found, potholes_missed;
  std::string Report() const;  ///< pooled figures and one line per scored frame
};

/// Scored: pixels nearer than the damage stage's analysed range (AnalysedRangeM of the frame's
/// truth disparity) that are not on truth damage of another type (cracks, patches, alligator
/// cracking: neither a hit nor a false alarm). Truth = pothole ids of truth/masks. Throws
/// InputError naming a missing or malformed file, std::invalid_argument on bad options.
SimSegmentEvaluation EvaluateSimulatedSegmentation(const std::filesystem::path& survey_dir,
                                                   const SimSegmentEvalOptions& options);

/// The same frames under several segmentation settings (options.damage with each `variants`
/// entry as its segment options), one evaluation per entry: each frame's disparity is computed
/// once. Debug overlays, when asked for, are those of the last variant.
std::vector<SimSegmentEvaluation> EvaluateSimulatedSegmentation(const std::filesystem::path& survey_dir,
                                                                const SimSegmentEvalOptions& options,
                                                                const std::vector<SegmentOptions>& variants);

}  // namespace rs
