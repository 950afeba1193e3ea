#include "stages/damage/noise/two_sided_noise.h"

#include "stages/damage/measure/measure.h"
#include "stages/damage/noise/relief_noise.h"
#include "survey/stats/robust_stats.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace rs {

cv::Mat TwoSidedReliefNoise(const cv::Mat& noise_up, const cv::Mat& value, const cv::Mat& valid, double level,
                            int cell_px, double floor_sigma, double max_ratio, double max_asymmetry,
                            const cv::Mat& instances) {
  if (noise_up.type() != CV_32FC1 || noise_up.size() != value.size())
    throw std::invalid_argument("TwoSidedReliefNoise: noise_up must be CV_32F of the value's size");
  if (!(max_asymmetry >= 1)) throw std::invalid_argument("TwoSidedReliefNoise: max_asymmetry >= 1 needed");
  if (!instances.empty() && (instances.type() != CV_16UC1 || instances.size() != value.size()))
    throw std::invalid_argument("TwoSidedReliefNoise: instances must be CV_16U of the value's size");
  // Mirrored about the level: the samples below become the samples above.
  const cv::Mat down = LocalReliefNoiseBelow(value, valid, level, cell_px, floor_sigma, max_ratio);
  // TwoSidedSigma per pixel in one pass (as cv::min of the scaled copy: OpenCV scales a float
  // image by the float factor, one rounding; both maps finite, never below the floor).
  const float k = static_cast<float>(max_asymmetry);
  cv::Mat out(value.size(), CV_32F);
  for (int v = 0; v < out.rows; ++v) {
    const float* up = noise_up.ptr<float>(v);
    const float* dn = down.ptr<float>(v);
    float* o = out.ptr<float>(v);
    for (int u = 0; u < out.cols; ++u) o[u] = TwoSidedSigma(up[u], dn[u], k);
  }
  if (instances.empty()) return out;
  // Leave-one-out per instance: its own walls are not the road's spread below. The box is grown
  // by two cells and aligned with the frame's cells, so the cells under the instance see the same
  // neighbours (fill, 3×3 smoothing) as in the frame's map.
  const std::vector<cv::Rect> boxes = LabelBoxes(instances);
  const cv::Rect frame({}, value.size());
  for (int id = 1; id < static_cast<int>(boxes.size()); ++id) {
    const cv::Rect& b = boxes[id];
    if (b.empty()) continue;
    const int x0 = std::max(0, (b.x / cell_px - 2) * cell_px), y0 = std::max(0, (b.y / cell_px - 2) * cell_px);
    const cv::Rect roi = cv::Rect(x0, y0, ((b.x + b.width - 1) / cell_px + 3) * cell_px - x0,
                                  ((b.y + b.height - 1) / cell_px + 3) * cell_px - y0) &
                         frame;
    const cv::Mat own = instances(roi) == id;
    const cv::Mat own_down =
        LocalReliefNoiseBelow(value(roi), valid(roi) & ~own, level, cell_px, floor_sigma, max_ratio);
    for (int v = b.y; v < b.y + b.height; ++v) {
      const uint16_t* l = instances.ptr<uint16_t>(v);
      const float* up = noise_up.ptr<float>(v);
      const float* dn = own_down.ptr<float>(v - roi.y) - roi.x;
      float* o = out.ptr<float>(v);
      for (int u = b.x; u < b.x + b.width; ++u)
        if (l[u] == id) o[u] = TwoSidedSigma(up[u], dn[u], k);
    }
  }
  return out;
}

}  // namespace rs
