#pragma once
// Internal helpers for reading OpenCV FileStorage YAML (the native calibration,
// ORB-SLAM2 settings, EuRoC sensor.yaml, Kalibr camchains) with errors that name
// the input file, its line where OpenCV reports one, and the key.

#include <opencv2/core/persistence.hpp>
#include <string>
#include <vector>

namespace rs::stereo_internal {

/// Parses YAML text with cv::FileStorage. Adds the "%YAML:1.0" directive OpenCV
/// needs when the file lacks it. Parse failures become InputError(path[:line]).
cv::FileStorage OpenYamlText(const std::string& text, const std::string& path);

/// Reads a whole stream into a string; throws InputError naming path on I/O failure.
std::string SlurpStream(std::istream& in, const std::string& path);
/// Reads a whole file; throws InputError when it is missing or unreadable.
std::string SlurpFile(const std::string& path);

/// A required real (int accepted) scalar; throws InputError naming key when absent or not numeric.
double RequireReal(const cv::FileNode& parent, const std::string& key, const std::string& path,
                   const std::string& key_path_for_errors = "");
/// A required int scalar.
int RequireInt(const cv::FileNode& parent, const std::string& key, const std::string& path,
               const std::string& key_path_for_errors = "");
/// A numeric matrix node: either "!!opencv-matrix" (rows/cols/data), a {rows, cols, data}
/// map without the tag (EuRoC T_BS), a flat sequence, or a sequence of row sequences
/// (Kalibr). Returns the values row-major; checks the element count when expected > 0.
std::vector<double> RequireNumbers(const cv::FileNode& parent, const std::string& key, const std::string& path,
                                   size_t expected, const std::string& key_path_for_errors = "");

}  // namespace rs::stereo_internal
