#pragma once
// Stereo rectification of a raw (distorted, unaligned) pair: cv::stereoRectify and
// cv::initUndistortRectifyMap run once; the maps are cached on disk keyed by the raw
// calibration so ingest computes them once per survey.

#include <array>
#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <optional>

#include "formats/stereo_calibration.h"

namespace rs {

/// Remap tables taking raw images to a rectified pair, plus the rectified calibration.
class StereoRectifier {
 public:
  /// Rectifies raw (which must pass CheckStereoCalibration and have known image sizes).
  /// alpha is stereoRectify's free scaling: 0 keeps only valid pixels (no black borders),
  /// 1 keeps every raw pixel. An already rectified calibration gives an identity rectifier.
  /// Throws InputError when the rig is vertical (|t_y| > |t_x|): epipolar lines would be columns.
  static StereoRectifier Create(const StereoCalibration& raw, double alpha = 0);

  /// Reads the cache at path when it exists and was made from exactly this raw calibration
  /// and alpha; otherwise computes the maps and (re)writes the cache. loaded_from_cache,
  /// when given, tells which happened. A corrupt cache is an InputError, not silently redone.
  static StereoRectifier LoadOrCreate(const StereoCalibration& raw, const std::filesystem::path& cache_path,
                                      double alpha = 0, bool* loaded_from_cache = nullptr);

  /// Binary cache: magic, key (raw calibration + alpha), rectified calibration, rotations,
  /// fixed-point maps (CV_16SC2 + CV_16UC1 per camera), XXH64 checksum. ~12 bytes/pixel.
  void Save(const std::filesystem::path& path) const;
  /// nullopt when the file's key does not match raw/alpha; InputError when it is corrupt.
  static std::optional<StereoRectifier> Load(const std::filesystem::path& path, const StereoCalibration& raw,
                                             double alpha = 0);

  /// Remaps a raw pair (any type cv::remap takes) to the rectified geometry (bilinear).
  void Rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat* left_rect, cv::Mat* right_rect) const;

  const StereoCalibration& raw() const { return raw_; }
  /// rectified = true, equal intrinsics, zero distortion, R = I, t = (-B, 0, 0).
  const StereoCalibration& rectified() const { return rect_; }
  /// Rotation taking left raw camera coordinates into the rectified left frame (R1), row-major.
  const std::array<double, 9>& R_rectleft_left() const { return R_rectleft_left_; }
  /// Same for the right camera (R2).
  const std::array<double, 9>& R_rectright_right() const { return R_rectright_right_; }
  /// True when raw was already rectified and Rectify copies images through.
  bool is_identity() const { return identity_; }

 private:
  StereoCalibration raw_, rect_;
  double alpha_ = 0;
  bool identity_ = false;
  std::array<double, 9> R_rectleft_left_{1, 0, 0, 0, 1, 0, 0, 0, 1}, R_rectright_right_{1, 0, 0, 0, 1, 0, 0, 0, 1};
  cv::Mat map1_left_, map2_left_, map1_right_, map2_right_;
};

}  // namespace rs
