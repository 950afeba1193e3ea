#pragma once
// roadsurvey's native stereo calibration file, calibration.yaml (OpenCV FileStorage
// YAML). Keys, exactly and only:
//   format: "roadsurvey-stereo-calibration-v1"
//   rectified: 0 | 1
//   image_width, image_height          (ints, px; both cameras share the size)
//   K_left, K_right                    (3x3 opencv-matrix)
//   D_left, D_right                    (1x5 opencv-matrix: k1 k2 p1 p2 k3)
//   R_right_left                       (3x3), t_right_left (3x1, metres):
//                                      p_right = R_right_left * p_left + t_right_left
// See docs/formats/stereo-sources.md.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/stereo_calibration.h"

namespace rs {

/// The value of the "format" key identifying the native calibration file.
inline constexpr const char* kNativeCalibrationFormat = "roadsurvey-stereo-calibration-v1";

/// Writes calib in the native format (full double precision, so reading it back is exact).
/// Throws InputError if calib fails CheckStereoCalibration or the sizes of the cameras differ,
/// so an impossible calibration is never written.
void WriteCalibrationYaml(std::ostream& out, const StereoCalibration& calib);
/// Path wrapper; throws InputError when the file cannot be written.
void WriteCalibrationYaml(const std::filesystem::path& path, const StereoCalibration& calib);

/// Reads and checks a native calibration. Missing, unknown or malformed keys and implausible
/// values throw InputError naming path_for_errors and the key. source_path is set to path_for_errors.
StereoCalibration ReadCalibrationYaml(std::istream& in, const std::string& path_for_errors);
StereoCalibration ReadCalibrationYaml(const std::filesystem::path& path);

}  // namespace rs
