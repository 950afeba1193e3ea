#pragma once
// Plausibility checks on a StereoCalibration, shared by every calibration reader
// so a typo (focal length in metres, baseline in millimetres, a transposed R)
// is caught at ingest instead of producing a warped survey.

#include <string>

#include "formats/stereo_calibration.h"

namespace rs {

/// Limits applied by CheckStereoCalibration. Defaults cover every real rig we
/// know of (baselines from a few millimetres to a few metres).
struct CalibrationLimits {
  double min_baseline_m = 0.001;         ///< below this the pair has no depth resolution
  double max_baseline_m = 10.0;          ///< above this the file is almost surely in mm
  double max_focal_px = 1e6;             ///< focal lengths beyond this are not a camera
  double principal_point_margin = 0.25;  ///< cx may lie in [-m*w, (1+m)*w], likewise cy
  double rotation_tolerance = 1e-5;      ///< max |R R^T - I| element and |det R - 1|
  double rectified_tolerance = 1e-6;     ///< rectified pairs: max |R - I|, |t_y|/B, |t_z|/B
};

/// Throws InputError (InputLocation::File(path)) naming the first offending field,
/// e.g. "K_left.fx = -3 violates fx > 0". Image sizes of 0 mean "unknown" (KITTI
/// calib.txt carries none) and skip the principal-point check; negative sizes fail.
void CheckStereoCalibration(const StereoCalibration& calib, const std::string& path,
                            const CalibrationLimits& limits = {});

/// Projects a nearly orthonormal row-major 3x3 matrix onto SO(3) (SVD). Used by
/// readers that compose rotations from values printed with few digits (Kalibr,
/// KITTI), whose products are orthonormal only to ~1e-5.
std::array<double, 9> NearestRotation(const std::array<double, 9>& R_rowmajor);

}  // namespace rs
