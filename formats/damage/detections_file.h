#pragma once
// One frame's damage detections as the damage stage writes them (`detections.json`, schema
// "roadsurvey.damage_detections/1"): the contract between the damage stage and its readers
// (the damage map). Metric fields are NaN where the stage could not measure them.

#include <filesystem>
#include <iosfwd>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rs {

/// One detected damage in one frame (see docs/stages/damage.md for each field's meaning).
struct DamageDetection {
  int id = 0;
  std::string type;                          ///< "pothole", "crack" or "other"
  std::vector<Eigen::Vector2i> outline_px;   ///< outer boundary in the left image, pixels
  std::vector<Eigen::Vector3d> outline_cam;  ///< the outline on the road surface, left camera frame, m
  int pixel_count = 0;
  double area_m2 = 0, sigma_area_m2 = 0;
  double max_depth_m = 0, max_depth_seen_m = 0, max_depth_bound_m = 0;
  double mean_depth_m = 0;
  double volume_m3 = 0, volume_seen_m3 = 0, volume_upper_m3 = 0, sigma_volume_m3 = 0;
  double equivalent_diameter_m = 0, max_diameter_m = 0;
  double length_m = 0, mean_width_m = 0, max_width_m = 0;
  double range_m = 0, sigma_depth_m = 0;
  double confidence = 0;
  bool floor_visible = true;
};

/// A frame's detections.json.
struct FrameDetections {
  int64_t frame = 0;
  int64_t t_ns = 0;
  /// Camera depth beyond which the stage did not look for damage, m (infinite: no limit, or not stated).
  double analysed_range_m = std::numeric_limits<double>::infinity();
  std::vector<DamageDetection> detections;
};

/// Throws InputError naming `path_for_errors` (and the detection) on malformed JSON, a wrong
/// schema or a missing/ill-typed field. A JSON null number reads as NaN.
FrameDetections ReadFrameDetections(std::istream& in, const std::string& path_for_errors);
FrameDetections ReadFrameDetections(const std::filesystem::path& path);

}  // namespace rs
