#pragma once
// A pothole reconstructed by our disparity against a laser scan of its gypsum mould (Fan et al. 2021,
// pothole_recon_fan2021/model3): cut the pothole from the reconstruction, register it to the scan by
// ICP, report the RMS closest-point distance. docs/evaluation.md ("Potholes against laser scans").

#include <filesystem>
#include <string>
#include <vector>

#include "stages/disparity/road_model.h"

namespace rs {

/// Options of EvaluatePotholeScan.
struct PotholeScanOptions {
  /// Deepest damage (below the road plane) the GPT-SGM residual range must hold, m: delta is the
  /// largest disparity drop of a point this far below the road anywhere in the view.
  double max_depth_m = 0.1;
  /// The pothole is cut where the reconstruction lies more than this many robust standard
  /// deviations (1.4826 MAD) of the road's own depth scatter below the road plane.
  double cut_sigma = 3.0;
  bool sharp = true;        ///< reconstruct from disparity_sharp (walls in place) instead of the smooth value
  int yaw_starts = 12;      ///< coarse alignment: ICP started from this many yaws about the road normal
  int coarse_points = 4000; ///< points of the reconstruction used for the coarse ICP runs
  int max_points = 30000;   ///< points used for the final ICP and the RMS (an even subsample)
  double icp_max_correspondence_mm = 10;  ///< ICP pairs farther apart are ignored
  int icp_iterations = 50;                ///< per ICP run
};

/// Result for one pair and one scan.
struct PotholeScanResult {
  RoadModel road;               ///< sparse road model of the pair
  bool fell_back = false;       ///< GPT-SGM fell back to plain SGM
  double delta_px = 0;          ///< GPT-SGM delta used (from max_depth_m)
  int num_disparities = 0;      ///< residual range searched
  double camera_height_m = 0;   ///< camera centre above the fitted road plane
  double road_sigma_mm = 0;     ///< robust scatter of the road points about the plane
  double cut_mm = 0;            ///< depth threshold of the pothole cut
  int64_t region_px = 0;        ///< pixels of the pothole region (holes filled)
  int points = 0;               ///< reconstructed points in the region (all valid pixels)
  double max_depth_mm = 0;      ///< deepest reconstructed point below the road plane (99.9th percentile)
  int scan_points = 0;          ///< points of the laser scan
  double scan_depth_mm = 0;     ///< the scan's extent along its z axis (the mould's height)
  double yaw_deg = 0;           ///< coarse yaw whose ICP run won
  double rms_mm = 0;            ///< RMS closest-point distance, reconstruction to scan, after ICP
  double median_mm = 0;         ///< median of the same distances
  double icp_fitness_mm2 = 0;   ///< PCL's fitness score of the final run (mean squared, within the gate)
};

/// Reconstructs the pair (left, right: rectified images; calibration_yaml: roadsurvey format) at full
/// resolution with the disparity stage's defaults (plus the focal length, and delta from
/// max_depth_m), cuts the pothole and registers it to `scan_ply` (points in mm, z = the mould's
/// height). Throws InputError for unreadable inputs, std::runtime_error when no road model or no
/// pothole region is found.
PotholeScanResult EvaluatePotholeScan(const std::filesystem::path& left, const std::filesystem::path& right,
                                      const std::filesystem::path& calibration_yaml,
                                      const std::filesystem::path& scan_ply, const PotholeScanOptions& options = {});

/// One row of the dataset's evaluation: pair index, scan file, result.
struct PotholeScanRow {
  int pair = 0;
  std::string scan;
  PotholeScanResult result;
};

/// The model3 folder (left images/L<i>.png, right images/R<i>.png, calibration_rectified.yaml,
/// gt/model_<k>.ply): `pairs[k]` is the pair whose pothole gt/model_<k+1>.ply scanned.
std::vector<PotholeScanRow> EvaluatePotholeScans(const std::filesystem::path& model3_dir, const std::vector<int>& pairs,
                                                 const PotholeScanOptions& options = {});

/// Markdown table of the rows.
std::string PotholeScanTable(const std::vector<PotholeScanRow>& rows);

}  // namespace rs
