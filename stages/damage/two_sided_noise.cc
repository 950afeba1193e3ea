#include "stages/damage/two_sided_noise.h"

#include "stages/damage/relief_noise.h"

#include <algorithm>
#include <stdexcept>

namespace rs {

cv::Mat TwoSidedReliefNoise(const cv::Mat& noise_up, const cv::Mat& value, const cv::Mat& valid, double level,
                            int cell_px, double floor_sigma, double max_ratio, double max_asymmetry) {
  if (noise_up.type() != CV_32FC1 || noise_up.size() != value.size())
    throw std::invalid_argument("TwoSidedReliefNoise: noise_up must be CV_32F of the value's size");
  if (!(max_asymmetry >= 1)) throw std::invalid_argument("TwoSidedReliefNoise: max_asymmetry >= 1 needed");
  // Mirrored about the level: the samples below become the samples above.
  const cv::Mat down = LocalReliefNoiseBelow(value, valid, level, cell_px, floor_sigma, max_ratio);
  // min(noise_up, down · max_asymmetry) in one pass (as cv::min of the scaled copy: OpenCV scales
  // a float image by the float factor, one rounding; both maps finite, never below the floor).
  const float k = static_cast<float>(max_asymmetry);
  cv::Mat out(value.size(), CV_32F);
  for (int v = 0; v < out.rows; ++v) {
    const float* up = noise_up.ptr<float>(v);
    const float* dn = down.ptr<float>(v);
    float* o = out.ptr<float>(v);
    for (int u = 0; u < out.cols; ++u) o[u] = std::min(up[u], dn[u] * k);
  }
  return out;
}

}  // namespace rs
