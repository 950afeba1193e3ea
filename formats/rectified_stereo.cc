#include "formats/rectified_stereo.h"

#include <cmath>

#include "formats/stereo_calibration.h"

namespace rs {

bool RectifiedStereo::Valid() const {
  return std::isfinite(f_px) && f_px > 0 && std::isfinite(baseline_m) && baseline_m > 0 && std::isfinite(cx_px) &&
         std::isfinite(cy_px);
}

RectifiedStereo RectifiedStereoOf(const StereoCalibration& calibration) {
  const CameraIntrinsics& left = calibration.left;
  return RectifiedStereo{left.fx, left.cx, left.cy, calibration.BaselineM(), left.width, left.height};
}

}  // namespace rs
