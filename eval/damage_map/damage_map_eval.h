#pragma once
// `roadsurvey eval damage-map`: the damage_map stage's map (<output>/damage.geojson) of a simulated
// survey against the simulator's truth (truth/damages.geojson). Which truth damages the flight saw
// whole (truth/masks), one-to-one matching on the road plane (potholes by polygon overlap, cracks by
// how much of the true line the predicted one covers), detection counts, and each matched damage's
// errors against fixed tolerances and against the uncertainty the map states.
// Protocol: docs/evaluation.md ("Damage map against the simulator's truth").

#include "formats/geojson/geojson.h"

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rs {

/// The scoring rules; every threshold is stated in the output.
struct DamageMapEvalOptions {
  /// Truth potholes at least this wide (truth mean_diameter_m) are scored; smaller ones are
  /// matched but left out of recall and precision, m.
  double min_pothole_diameter_m = 0.3;
  /// Truth cracks (crack_longitudinal, crack_transverse) at least this long (truth length_m) are scored, m.
  double min_crack_length_m = 0.5;
  /// A predicted pothole matches a truth pothole when intersection / min(area_predicted,
  /// area_truth) on the road plane reaches this.
  double min_overlap = 0.3;
  /// Cell of the road-plane raster on which polygons are intersected, m.
  double cell_m = 0.005;
  /// A point of a true crack is covered when a predicted crack line passes within this distance, m.
  double crack_tolerance_m = 0.10;
  /// A predicted crack matches a truth crack when it covers at least this share of the true line.
  double min_crack_coverage = 0.5;
  /// Spacing of the samples along a true crack line, m.
  double crack_sample_m = 0.01;
  /// A truth damage is seen (whole) in a frame when its mask there has at least this many pixels...
  int min_seen_pixels = 50;
  /// ... and none of them lies in the outer `border_px` rows and columns of the image.
  int border_px = 2;
  /// A truth crack is also seen whole when the frames together saw this share of its line (its
  /// mask pixels placed on the map with the true disparity and pose, within crack_sample_m · 2).
  double min_line_seen = 0.95;
  /// Remove the cameras' mean placement error (<output>/cameras.csv against the truth poses) from
  /// the map before matching: a biased GNSS moves the whole map, which overlap matching would
  /// otherwise count as misses. Absolute centroid errors are reported either way.
  bool remove_placement_offset = true;
  /// Fixed tolerances of the summaries: |max depth error| (m), |area error| and |volume error| (%).
  double depth_tolerance_m = 0.010;
  double area_tolerance_pct = 10;
  double volume_tolerance_pct = 15;
  /// The stated uncertainty is the interval ± sigma_factor · σ (2: the 95 % interval).
  double sigma_factor = 2;

  /// Throws std::invalid_argument naming the rule broken: "min_overlap = 0 violates 0 < min_overlap <= 1".
  void Check() const;
  nlohmann::json ToJson() const;
};

/// How a truth damage was seen over the flight's frames.
enum class TruthSight {
  kUnseen,   ///< no pixel in any frame
  kPartial,  ///< some pixels, but never whole: not counted in recall, a prediction on it is no false positive
  kWhole,    ///< whole in at least one frame (DamageMapEvalOptions::min_seen_pixels, border_px)
};
const char* TruthSightName(TruthSight sight);

/// One truth damage's sightings over the frames.
struct TruthSighting {
  int frames_whole = 0;    ///< frames where it is seen whole
  int frames_partial = 0;  ///< frames with some of its pixels, not whole (cut by the border or too few pixels)
  int max_pixels = 0;      ///< most pixels in one frame
  /// Cracks: share of the true line that the frames together saw (NaN: not measured). A crack
  /// longer than one view is seen whole over the flight though no single frame holds it.
  double line_seen_over_frames = std::numeric_limits<double>::quiet_NaN();
  bool whole_over_frames = false;  ///< line_seen_over_frames reached DamageMapEvalOptions::min_line_seen
  TruthSight Sight() const {
    return frames_whole > 0 || whole_over_frames ? TruthSight::kWhole
           : frames_partial > 0                  ? TruthSight::kPartial
                                                 : TruthSight::kUnseen;
  }
};
/// By truth id; an id that is absent is unseen.
using TruthSightings = std::map<int, TruthSighting>;

/// Adds one frame's truth instance mask (CV_16UC1, 0 = background, else the truth feature id).
/// With a truth disparity (CV_32FC1, px) and a finite `max_range_m`, a pixel farther than
/// `max_range_m` (Z = bf_px_m / disparity) counts as cut like a border pixel: the damage stage did
/// not look beyond that range in the frame. Throws std::invalid_argument on another image type.
void AddFrameSightings(const cv::Mat& masks, const DamageMapEvalOptions& options, TruthSightings* sightings,
                       const cv::Mat& truth_disparity_px = cv::Mat(), double bf_px_m = 0,
                       double max_range_m = std::numeric_limits<double>::infinity());

/// Adds one frame's mask pixels of the truth ids in `ids` to `points` (by id), placed on the map
/// (x east, y north of the truth's ENU) with the frame's true disparity (px), camera
/// (f, cx, cy, baseline) and true left-camera-to-ENU pose.
void AddFramePixelsOnMap(const cv::Mat& masks, const cv::Mat& truth_disparity_px, double f_px, double cx_px,
                         double cy_px, double baseline_m, const cv::Matx44d& enu_from_camera,
                         const std::vector<int>& ids, std::map<int, std::vector<cv::Point2d>>* points);

/// Share of the polyline `line` (map metres) with a point of `seen` within `tolerance_m`, sampled
/// every `step_m`.
double LineSeenShare(const std::vector<cv::Point2d>& line, const std::vector<cv::Point2d>& seen, double tolerance_m,
                     double step_m);

/// The local ENU frame the truth is given in (truth/georeference.json "origin").
struct EnuOrigin {
  double lat_deg = 0, lon_deg = 0, h_ellipsoid_m = 0;
};

inline constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();

/// A predicted pothole matched to a truth pothole. Errors are predicted − truth; NaN where the map
/// or the truth gives no value. Verdicts are empty where they cannot be decided.
struct PotholeMatch {
  int predicted_id = 0, truth_id = 0;
  bool scored = true;  ///< false: the truth pothole is partial or smaller than min_pothole_diameter_m
  double overlap = 0;  ///< intersection / min(area_predicted, area_truth), road plane
  double iou = 0;
  double centroid_error_m = 0;  ///< horizontal distance between the polygons' area centroids, the map's
                                ///< placement offset removed (DamageMapEvaluation::placement_offset)
  double absolute_centroid_error_m = 0;  ///< the same as the map states it (offset kept)
  std::optional<bool> floor_visible;
  double truth_max_depth_m = kNoValue, truth_area_m2 = kNoValue, truth_volume_m3 = kNoValue;
  double max_depth_m = kNoValue, area_m2 = kNoValue, volume_m3 = kNoValue;
  double depth_error_mm = kNoValue, area_error_pct = kNoValue, volume_error_pct = kNoValue;
  /// Within the stated uncertainty: |error| <= sigma_factor·σ; where the floor is hidden, the true
  /// max depth within [max_depth_seen_m, max_depth_bound_m] and the true volume <= volume_upper_m3.
  std::optional<bool> depth_within_uncertainty, area_within_uncertainty, volume_within_uncertainty;
};

/// A predicted crack matched to a truth crack.
struct CrackMatch {
  int predicted_id = 0, truth_id = 0;
  bool scored = true;   ///< false: the truth crack is partial or shorter than min_crack_length_m
  double coverage = 0;  ///< share of the true line within crack_tolerance_m of the predicted one
  double truth_length_m = kNoValue, length_m = kNoValue;
  double length_error_pct = kNoValue;  ///< (predicted − truth length_m) / truth, %
};

/// A truth damage no prediction of its type matched.
struct MissedDamage {
  int truth_id = 0;
  int frames_whole = 0;  ///< frames that saw it whole
  /// A prediction of another type that would match it by the same rule (0 when none): the map
  /// found the damage but typed it otherwise.
  int typed_otherwise_id = 0;
  std::string typed_otherwise_as;
};

/// A further prediction matching a truth damage that another prediction already matched.
struct DuplicateDamage {
  int predicted_id = 0, truth_id = 0;
  double overlap = 0;  ///< potholes: overlap; cracks: coverage
};

/// A prediction matching no truth damage of its type, with the nearest truth damage of any type
/// (distance from the prediction's centroid to its geometry; 0 inside a polygon).
struct FalseDamage {
  int predicted_id = 0;
  cv::Point2d centroid_enu_m;  ///< x east, y north in the truth's ENU
  double lat_deg = 0, lon_deg = 0;
  double chainage_m = kNoValue, offset_m = kNoValue;  ///< as the map states them
  int nearest_truth_id = 0;                           ///< 0 when the truth is empty
  std::string nearest_truth_type;
  double nearest_truth_distance_m = kNoValue;
};

/// Detection counts of one type.
struct DamageTypeCounts {
  int truth = 0;       ///< truth damages of the type
  int seen = 0;        ///< scored: seen whole and at least the size threshold (the recall's denominator)
  int partial = 0;     ///< some pixels but never whole
  int unseen = 0;      ///< no pixel in any frame
  int small = 0;       ///< seen whole but below the size threshold
  int predicted = 0;   ///< predictions of the type
  int matched = 0;     ///< predictions matched one-to-one to a scored truth damage
  int unscored = 0;    ///< predictions matched (or duplicating) a partial or small truth damage; cracks also within alligator cracking
  int duplicates = 0;  ///< further predictions on an already matched scored truth damage
  int false_positives = 0;
  int misses = 0;  ///< scored truth damages without a match
  /// matched / seen; matched / (matched + duplicates + false positives); NaN with a zero denominator.
  double recall = kNoValue, precision = kNoValue;
};

/// |error| figures over the scored matches that have a value.
struct ErrorSummary {
  int n = 0;
  double median_abs = kNoValue, max_abs = kNoValue, min_abs = kNoValue;
  double tolerance = kNoValue;  ///< NaN: no fixed tolerance for this figure
  int within_tolerance = 0;
  int judged = 0;  ///< matches whose stated uncertainty decides the figure
  int within_uncertainty = 0;
};

/// Counts of truth damages that are not scored (alligator_cracking, patch, ...).
struct OtherTruthCounts {
  int truth = 0, seen = 0, partial = 0, unseen = 0;
};

/// The whole evaluation.
struct DamageMapEvaluation {
  DamageMapEvalOptions options;
  std::string truth_path, predicted_path;  ///< as named in the output
  int frames = 0;                          ///< frames whose masks gave the sightings (0: given)

  DamageTypeCounts potholes, cracks;
  std::vector<PotholeMatch> pothole_matches;  ///< scored and unscored, by truth id
  std::vector<MissedDamage> pothole_misses;
  std::vector<DuplicateDamage> pothole_duplicates;
  std::vector<FalseDamage> pothole_false_positives;
  /// The cameras' mean horizontal placement error (ours − truth, east and north, m). Each damage
  /// is moved back by the mean error of the cameras that observed it before matching. Zero when
  /// not measured.
  cv::Point2d placement_offset_m{0, 0};
  int placement_frames = 0;  ///< cameras the offset was measured on (0: not measured)
  ErrorSummary centroid_error_m, absolute_centroid_error_m, iou, depth_error_mm, area_error_pct, volume_error_pct;
  int floor_hidden = 0;  ///< scored matches whose floor the map says it did not see

  std::vector<CrackMatch> crack_matches;
  std::vector<MissedDamage> crack_misses;
  std::vector<DuplicateDamage> crack_duplicates;
  std::vector<FalseDamage> crack_false_positives;
  ErrorSummary crack_length_error_pct, crack_coverage;

  std::map<std::string, OtherTruthCounts> other_truth;  ///< by truth type
  int predicted_other = 0;                              ///< predictions typed "other" (not scored)

  /// The table for people: per type counts, per-pothole and per-crack rows, summaries, lists.
  std::string Table() const;
  /// Schema "roadsurvey.eval_damage_map/1".
  nlohmann::json ToJson() const;
};

/// Scores a predicted map against the truth, both RFC 7946 collections in WGS84 lon/lat, converted
/// to the local ENU at `origin`. Truth features need an integer id and a type; potholes
/// mean_diameter_m, area_m2, max_depth_m, volume_m3 (numbers); cracks length_m. Predicted features
/// need an integer id and a type ("pothole", "crack", "other"); their numbers may be null or absent.
/// Throws rs::InputError naming `truth_name` or `predicted_name` and the feature on a bad one.
/// The horizontal placement error (ours − truth, east and north, m) of each georeferenced camera.
struct CameraPlacement {
  std::map<int64_t, cv::Point2d> by_frame;
  cv::Point2d mean{0, 0};
};

/// With `placement`, each predicted damage is moved back by the mean placement error of the cameras
/// that observed it (its "observation_frames"; the overall mean when none is known) before matching:
/// the georeference's error, which the map inherits and which the georeference's own evaluation
/// measures, is kept apart from the map's. Absolute centroid errors keep it.
DamageMapEvaluation ScoreDamageMap(const geojson::FeatureCollection& truth, const geojson::FeatureCollection& predicted,
                                   const EnuOrigin& origin, const TruthSightings& sightings,
                                   const DamageMapEvalOptions& options, const std::string& truth_name = "truth",
                                   const std::string& predicted_name = "predicted",
                                   const CameraPlacement* placement = nullptr);

/// The run's georeferenced cameras (<output>/cameras.csv, rows with status "visual") against the
/// truth poses (truth/trajectory.tum, row k = frame k) in the truth's ENU. Throws rs::InputError
/// naming the file and line.
CameraPlacement ReadCameraPlacement(const std::filesystem::path& cameras_csv, const std::filesystem::path& truth_tum,
                                    const EnuOrigin& origin);

/// Reads truth/georeference.json's origin. Throws rs::InputError naming the file.
EnuOrigin ReadEnuOrigin(const std::filesystem::path& georeference_json);

/// The survey's output folder: `output_dir` when not empty, else survey.json's "output" (relative
/// to the survey folder). Throws rs::InputError naming survey.json when it is missing or malformed.
std::filesystem::path SurveyOutputDir(const std::filesystem::path& survey_dir, const std::filesystem::path& output_dir);

/// Evaluates a `roadsurvey simulate` folder after `roadsurvey run`: reads every frame's truth mask,
/// the truth and <output>/damage.geojson. Throws rs::InputError naming a missing or malformed file,
/// std::invalid_argument on bad options.
DamageMapEvaluation EvaluateDamageMap(const std::filesystem::path& survey_dir, const std::filesystem::path& output_dir,
                                      const DamageMapEvalOptions& options);

}  // namespace rs
