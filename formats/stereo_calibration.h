#pragma once
// A calibrated stereo pair in OpenCV's stereoCalibrate convention.
// Native file format (OpenCV FileStorage YAML): docs/formats/stereo-sources.md, "calibration.yaml".

#include <array>
#include <string>

namespace rs {

/// Pinhole intrinsics with OpenCV (k1, k2, p1, p2, k3) radial-tangential distortion.
struct CameraIntrinsics {
  int width = 0, height = 0;     ///< image size, px
  double fx = 0, fy = 0;         ///< focal lengths, px
  double cx = 0, cy = 0;         ///< principal point, px
  std::array<double, 5> dist{};  ///< k1, k2, p1, p2, k3
};

/// Left = reference camera. R_right_left, t_right_left map a point from the left
/// camera frame into the right one: p_right = R_right_left * p_left + t_right_left.
/// For a rectified pair R is identity, dist is zero, both intrinsics are equal and
/// t_right_left = (-baseline_m, 0, 0).
struct StereoCalibration {
  CameraIntrinsics left, right;
  std::array<double, 9> R_right_left{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major
  std::array<double, 3> t_right_left{0, 0, 0};                    ///< metres
  bool rectified = false;  ///< true: images are already rectified (no remap needed)
  std::string source_path;

  double BaselineM() const;  ///< |t_right_left|
};

}  // namespace rs
