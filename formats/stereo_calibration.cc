#include "formats/stereo_calibration.h"

#include <cmath>

namespace rs {

double StereoCalibration::BaselineM() const {
  return std::sqrt(t_right_left[0] * t_right_left[0] + t_right_left[1] * t_right_left[1] +
                   t_right_left[2] * t_right_left[2]);
}

}  // namespace rs
