#pragma once
// The rectified stereo pair every stage works in: one pinhole (focal length, principal point)
// shared by both views, the right view shifted by the baseline along x, so Z = f·B / d.

namespace rs {

struct StereoCalibration;

/// Rectified stereo geometry of the reference (left) camera.
struct RectifiedStereo {
  double f_px = 0;        ///< focal length, px (fx of the rectified pair)
  double cx_px = 0;       ///< principal point column, px
  double cy_px = 0;       ///< principal point row, px
  double baseline_m = 0;  ///< stereo baseline, m
  int width = 0;          ///< image width, px (0 = not known)
  int height = 0;         ///< image height, px (0 = not known)
  /// True when f and B are positive and finite (principal point may be anywhere).
  bool Valid() const;
  /// Disparity × depth, px·m: Z = bf() / d.
  double bf() const { return f_px * baseline_m; }
};

/// The rectified geometry of a rectified calibration: the left camera's fx, cx, cy, its
/// image size and the baseline |t_right_left|.
RectifiedStereo RectifiedStereoOf(const StereoCalibration& calibration);

}  // namespace rs
