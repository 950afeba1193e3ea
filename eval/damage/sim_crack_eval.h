#pragma once
// Evaluation of the crack detector on a `roadsurvey simulate` folder: per frame, disparity
// (ours or the simulator's truth) -> DetectDamage, crack-typed detections compared with the
// truth crack masks (pixel precision/recall within a tolerance band), with each truth crack's
// centreline (truth/damages.geojson) projected into the frame (instance recall, length of the
// visible part, width). Protocol and figures: docs/results/damage.md ("Crack evaluation").

#include "stages/damage/damage_pipeline.h"
#include "eval/damage/sim_damage_eval.h"
#include "stages/disparity/disparity.h"

#include <filesystem>
#include <string>
#include <vector>

namespace rs {

/// What to evaluate and how.
struct SimCrackEvalOptions {
  bool use_truth_disparity = false;  ///< true: truth/disparity (isolates the damage stage); false: ComputeDisparity
  DisparityParams disparity;         ///< used when use_truth_disparity is false
  DamageOptions damage;
  /// Tolerance band for thin structures: a detected pixel is correct within this distance of a
  /// truth crack pixel, a truth pixel found within it of a detected one, px.
  int tolerance_px = 3;
  /// A truth crack is scored in a frame when at least this much of its centreline is visible
  /// within the damage stage's analysed range (FrameDamage::analysed_range_m), m.
  double min_visible_length_m = 0.3;
  /// ... and its width across the crack in the image (its edges on the road projected) is at
  /// least this many pixels on average: narrower cracks are below the image's resolution.
  double min_width_px = 1.0;
  /// A scored crack counts as found when at least this share of its truth pixels in range lies
  /// within the tolerance of crack-typed detections.
  double min_coverage = 0.5;
  /// A detection belongs to the truth crack holding most of its pixels (within the tolerance)
  /// when that crack holds at least this share of them; else it is false unless it lies on
  /// other truth cracking (alligator areas), which is not scored.
  double min_detection_share = 0.5;
  int frame_step = 1;  ///< evaluate every n-th frame
  int max_frames = 0;  ///< 0 = all
  /// Non-empty: writes an overlay per frame (truth crack pixels green, detected crack pixels
  /// yellow where correct, red where false).
  std::filesystem::path debug_dir;
};

/// One scored truth crack in one frame.
struct CrackObservation {
  std::string frame;
  int truth_id = 0;
  double truth_width_m = 0;        ///< the simulator's crack width
  double truth_length_m = 0;       ///< whole crack
  double visible_length_m = 0;     ///< its centreline in the image, unoccluded and within the analysed range
  double range_m = 0;              ///< mean camera depth Z of the visible centreline
  double width_px = 0;             ///< mean width across the crack in the image
  double coverage = 0;             ///< share of its truth pixels in range within the tolerance of detections
  bool detected = false;           ///< coverage ≥ min_coverage
  double length_m = kUnknown;      ///< sum of the lengths of the detections assigned to it
  double mean_width_m = kUnknown;  ///< their length-weighted mean width
};

/// Aggregate over the evaluated frames.
struct SimCrackEvaluation {
  int frames = 0;
  long long truth_pixels = 0;              ///< centreline pixels of resolvable truth cracks within the analysed range
  long long truth_pixels_found = 0;        ///< of those: within the tolerance of a detected crack pixel
  long long detected_pixels = 0;           ///< crack-typed detection pixels
  long long detected_pixels_on_truth = 0;  ///< of those: within the tolerance of any truth crack (incl. alligator)
  double pixel_precision = 0, pixel_recall = 0, pixel_f1 = 0;
  std::vector<CrackObservation> observations;  ///< every scored (frame, truth crack)
  int unique_cracks = 0;
  int unresolved = 0;       ///< (frame, crack) pairs visible long enough but narrower than min_width_px
  double min_width_px = 0;  ///< the option used
  int detected = 0;         ///< observations found
  double instance_recall = 0;
  int detections = 0;                   ///< crack-typed detections
  int false_detections = 0;             ///< of those: on no truth crack (see min_detection_share)
  double false_area_m2_per_frame = 0;   ///< road-plane area of false crack pixels per frame
  double false_length_m_per_frame = 0;  ///< reported length of false detections per frame
  DamageErrorStats length_error_pct;    ///< found cracks: (measured − visible length) / visible length, %
  DamageErrorStats width_error_mm;      ///< found cracks: measured mean width − truth width, mm
  double ms_cracks_median = 0;          ///< crack step of DetectDamage (wall), ms
  /// Multi-line human-readable summary of every figure above, one line per observation when
  /// `per_observation`.
  std::string Report(bool per_observation = false) const;
};

/// Evaluates the survey folder written by Simulate() (needs left/, right/, calibration.yaml,
/// truth/{masks,disparity,damages.geojson,trajectory.tum,scene.json,georeference.json}).
/// Throws rs::InputError when a file is missing or malformed, std::invalid_argument on bad options.
SimCrackEvaluation EvaluateSimulatedCracks(const std::filesystem::path& survey_dir, const SimCrackEvalOptions& options);

}  // namespace rs
