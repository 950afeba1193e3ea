#include "stages/damage/two_sided_noise.h"

#include "stages/damage/relief_noise.h"

#include <stdexcept>

namespace rs {

cv::Mat TwoSidedReliefNoise(const cv::Mat& noise_up, const cv::Mat& value, const cv::Mat& valid, double level,
                            int cell_px, double floor_sigma, double max_ratio, double max_asymmetry) {
  if (noise_up.type() != CV_32FC1 || noise_up.size() != value.size())
    throw std::invalid_argument("TwoSidedReliefNoise: noise_up must be CV_32F of the value's size");
  if (!(max_asymmetry >= 1)) throw std::invalid_argument("TwoSidedReliefNoise: max_asymmetry >= 1 needed");
  // Mirrored about the level: the samples below become the samples above.
  const cv::Mat mirrored = -value;
  const cv::Mat down = LocalReliefNoise(mirrored, valid, -level, cell_px, floor_sigma, max_ratio);
  return cv::min(noise_up, down * max_asymmetry);  // both never below the floor
}

}  // namespace rs
