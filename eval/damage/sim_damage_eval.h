#pragma once
// Evaluation of the damage pipeline on a `roadsurvey simulate` folder: per frame,
// disparity (ours or the simulator's truth) -> DetectDamage, detected potholes
// matched to the truth instance masks at IoU >= 0.5, measurements compared with
// truth/damages.geojson, severity with the truth grade, obstacles checked.
// Protocol and measured figures: docs/results/damage.md ("Simulator evaluation").

#include "stages/damage/damage_pipeline.h"
#include "stages/disparity/disparity.h"

#include <filesystem>
#include <string>
#include <vector>

namespace rs {

/// What to evaluate and how.
struct SimDamageEvalOptions {
  bool use_truth_disparity = false;  ///< true: truth/disparity (isolates the damage stage); false: ComputeDisparity
  DisparityParams disparity;         ///< used when use_truth_disparity is false
  /// With ComputeDisparity: pass its sharp image (DisparityResult::disparity_sharp) to DetectDamage,
  /// as the job graph does (the truth disparity has one image).
  bool use_sharp_disparity = true;
  DamageOptions damage;
  double min_diameter_m = 0.3;  ///< truth potholes at least this wide (mean_diameter_m) are scored
  double min_iou = 0.5;         ///< detection ↔ truth mask IoU needed for a match
  /// Only potholes whose mean camera depth (truth) is nearer are scored; 0 = the damage stage's
  /// analysed range in each frame (FrameDamage::analysed_range_m).
  double max_range_m = 0;
  /// Only potholes whose true max depth reaches damage.measure.pothole_min_depth_sigma × σ_Z at
  /// their range (σ_Z with damage.measure.sigma_disparity_px) are scored: shallower ones are by
  /// the stage's stated rule not confirmable there (see docs/stages/damage.md).
  bool require_confirmable_depth = true;
  int frame_step = 1;               ///< evaluate every n-th frame
  int max_frames = 0;               ///< 0 = all
  double obstacle_margin_m = 0.05;  ///< truth obstacle volume grown by this much
  /// Non-empty: writes overlays (truth outlines green/cyan) and depth images of frames with a miss
  /// or a false detection there, and prints the road fit and overlaps of misses to stderr.
  std::filesystem::path debug_dir;
  bool debug_all_frames = false;  ///< with debug_dir: write every frame, not only those with a problem
};

/// One scored truth pothole in one frame.
struct PotholeObservation {
  std::string frame;
  int truth_id = 0;
  bool detected = false;  ///< matched by a pothole-typed detection
  double iou = 0;
  double truth_max_depth_m = 0, truth_area_m2 = 0, truth_volume_m3 = 0;
  std::string truth_severity;  ///< "L", "M", "H"
  double range_m = 0;          ///< mean camera depth Z of the pothole's pixels (truth disparity)
  /// Deepest point of the pothole seen in this frame: largest depth below the intact road of
  /// its truth-disparity points. Less than truth_max_depth_m where the near rim hides the floor
  /// (oblique views): no single frame can measure more.
  double truth_visible_depth_m = 0;
  /// Volume of the surface seen in this frame: Σ over the mask's pixels of the seen point's depth
  /// below the intact road × the pixel's area on the intact road (the stage's own volume model
  /// applied to the truth). Less than truth_volume_m3 where the floor is hidden.
  double truth_visible_volume_m3 = 0;
  /// The stage's estimates (DamageInstance::max_depth_m, volume_m3: the hidden part completed)
  /// and what the frame sees (max_depth_seen_m, volume_seen_m3).
  double max_depth_m = kUnknown, area_m2 = kUnknown, volume_m3 = kUnknown, sigma_depth_m = kUnknown;
  double max_depth_seen_m = kUnknown, volume_seen_m3 = kUnknown;
  double sigma_area_m2 = kUnknown, sigma_volume_m3 = kUnknown;  ///< the stage's stated uncertainties
  SeverityLevel astm = SeverityLevel::kNone;
  /// The stage's line-of-sight verdict on the match (DamageInstance::floor_visible) and its
  /// bounds where it says hidden.
  bool floor_visible = true;
  double max_depth_bound_m = kUnknown, volume_upper_m3 = kUnknown;
  /// Truth: the floor is hidden in this frame (visible depth > 10 mm short of the true depth).
  bool truth_floor_hidden = false;

  /// The stage's errors against the truth (detected observations): max depth in mm, area and
  /// volume in % of the true value.
  double MaxDepthErrorMm() const { return 1000.0 * (max_depth_m - truth_max_depth_m); }
  double AreaErrorPct() const { return 100.0 * (area_m2 - truth_area_m2) / truth_area_m2; }
  double VolumeErrorPct() const { return 100.0 * (volume_m3 - truth_volume_m3) / truth_volume_m3; }
};

/// Distribution of an error over the matched observations.
struct DamageErrorStats {
  int n = 0;
  double mean = 0;        ///< signed mean (bias)
  double median_abs = 0;  ///< median |error|
  double p95_abs = 0;     ///< 95th percentile |error|
  double max_abs = 0;     ///< largest |error|
};

/// Aggregate over the evaluated frames.
struct SimDamageEvaluation {
  int frames = 0;
  std::vector<PotholeObservation> observations;  ///< every scored (frame, truth pothole)
  int unique_potholes = 0;                       ///< distinct truth ids among the observations
  int detected = 0;                              ///< observations matched
  int detections = 0;                            ///< pothole-typed detections not touching the border
  int false_positives = 0;                       ///< of those: no match and < 50 % of pixels on any truth damage
  int ignored_detections = 0;   ///< of those: on unscored truth damage (small potholes, cracks, patches)
  int obstacle_detections = 0;  ///< detections of any type with ≥ 50 % of their pixels on an obstacle
  double recall = 0, precision = 0;
  DamageErrorStats depth_error_mm;            ///< estimated − truth max depth, mm (every match)
  DamageErrorStats visible_depth_error_mm;    ///< seen (max_depth_seen_m) − truth depth visible in the frame, mm
  DamageErrorStats visible_volume_error_pct;  ///< (seen − visible truth volume) / visible truth volume, %
  int occluded = 0;       ///< matched observations whose visible depth is > 10 mm less than the true depth
  int unconfirmable = 0;  ///< truth potholes in range left unscored: shallower than the σ_Z rule allows
  /// The accuracy errors against the true values, scored only where the stage says it saw
  /// the whole: max depth where floor_visible, volume where no volume_upper_m3 is stated.
  DamageErrorStats seen_depth_error_mm, seen_volume_error_pct;
  /// Where the stage says the floor is hidden: matches, and how many hold the true max depth
  /// within the stated interval [max_depth_seen_m − 2 σ_Z, max_depth_bound_m].
  int hidden_matches = 0, hidden_depth_contained = 0;
  DamageErrorStats hidden_bound_ratio;              ///< max_depth_bound_m / true max depth (how loose the bound is)
  DamageErrorStats hidden_depth_estimate_error_mm;  ///< there: estimated − true max depth, mm
  /// Where the stage states a volume upper bound: matches, and how many hold the true volume
  /// within [volume_seen_m3 − 2 σ_Z·area_m2, volume_upper_m3].
  int volume_bounded_matches = 0, hidden_volume_contained = 0;
  DamageErrorStats volume_upper_ratio;                 ///< volume_upper_m3 / true volume
  DamageErrorStats bounded_volume_estimate_error_pct;  ///< there: (estimated − true) / true volume, %
  /// The flag against the truth (floor hidden by > 10 mm): agreements over the matches, and
  /// the two kinds of disagreement.
  int flag_agreements = 0, flagged_hidden_truth_seen = 0, flagged_seen_truth_hidden = 0;
  int hidden_flag_detections = 0;     ///< pothole detections (as counted in `detections`) flagged hidden
  DamageErrorStats area_error_pct;    ///< (measured − truth) / truth area, %
  DamageErrorStats volume_error_pct;  ///< (estimated − truth) / truth volume, % (every match)
  double depth_within_2sigma = 0;     ///< share of matches with |depth error| ≤ 2 σ_Z
  double mean_sigma_depth_mm = 0;     ///< mean σ_Z of the matches, mm
  /// The stated area uncertainty: share of matches with |area error| ≤ 2 σ_area, and the mean
  /// σ_area relative to the measured area, %.
  double area_within_2sigma = 0, mean_sigma_area_pct = 0;
  /// The stated volume uncertainty where the volume is seen (no upper bound): share of those
  /// matches with |volume error| ≤ 2 σ_volume, and the mean σ_volume relative to the volume, %.
  double volume_within_2sigma = 0, mean_sigma_volume_pct = 0;
  double severity_agreement = 0;        ///< share of matches whose ASTM level equals the truth severity
  double road_median_abs_mm = 0;        ///< median |height of the true intact road above the fitted surface|, mm
  double disparity_valid_fraction = 0;  ///< mean share of valid disparities
  double ms_damage_median = 0, ms_damage_max = 0;  ///< DetectDamage wall time per frame
  double ms_disparity_median = 0;                  ///< ComputeDisparity wall time (0 with truth disparity)
  std::vector<PassTime> pass_ms_median;  ///< median wall time of each pass of DetectDamage (DamagePassNames order)
  double cpu_ms_damage_median = 0;       ///< DetectDamage process CPU time (all threads): the one-core bound
  int width = 0, height = 0;
  double max_range_m = 0;                             ///< scored range used (the largest over the frames)
  std::vector<std::string> false_detections;          ///< "frame id: area, depth, bbox" of each false positive
  std::vector<std::string> obstacle_detection_lines;  ///< "frame id type: area, depth, bbox" of each obstacle detection
  /// Multi-line human-readable summary of every figure above.
  std::string Report() const;
};

/// Evaluates the survey folder written by Simulate() (needs left/, right/, calibration.yaml,
/// truth/{masks,disparity,damages.geojson,trajectory.tum,scene.json}). Throws rs::InputError
/// when a file is missing or malformed, std::invalid_argument on bad options.
SimDamageEvaluation EvaluateSimulatedDamage(const std::filesystem::path& survey_dir,
                                            const SimDamageEvalOptions& options);

/// Statistics of a list of errors (empty: n = 0, all zero).
DamageErrorStats ComputeDamageErrorStats(std::vector<double> errors);

}  // namespace rs
