#include "stages/damage/measure/sharp_disparity.h"

#include "stages/damage/measure/measure.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace rs {

cv::Mat SharpDepthBelowMm(const cv::Mat& sharp, const cv::Mat& disparity_px, const cv::Mat& labels,
                          const RectifiedStereo& g, const RoadSurface& s, const cv::Mat& correction_mm) {
  if (sharp.type() != CV_32FC1 || disparity_px.type() != CV_32FC1 || sharp.size() != disparity_px.size())
    throw std::invalid_argument("sharp disparity: CV_32F of the disparity's size expected");
  if (labels.type() != CV_16UC1 || labels.size() != sharp.size() ||
      (!correction_mm.empty() && (correction_mm.type() != CV_32FC1 || correction_mm.size() != sharp.size())))
    throw std::invalid_argument(
        "sharp disparity: labels (CV_16U) and correction (CV_32F) of the disparity's size expected");
  cv::Mat out(sharp.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const double fb = g.f_px * g.baseline_m;
  const std::vector<cv::Rect> boxes = LabelBoxes(labels);
  for (size_t id = 1; id < boxes.size(); ++id) {
    const cv::Rect& b = boxes[id];
    for (int v = b.y; v < b.y + b.height; ++v) {
      const uint16_t* l = labels.ptr<uint16_t>(v);
      const float* d = disparity_px.ptr<float>(v);
      const float* ds = sharp.ptr<float>(v);
      float* o = out.ptr<float>(v);
      for (int u = b.x; u < b.x + b.width; ++u) {
        if (l[u] != id || !(d[u] > 0) || !(ds[u] > 0) || !std::isfinite(ds[u])) continue;
        const Eigen::Vector3d p = CameraPointAtDepth(g, u, v, fb / ds[u]);
        const double corr = correction_mm.empty() ? 0.0 : correction_mm.at<float>(v, u);
        o[u] = static_cast<float>(1000.0 * s.DepthBelow(p) - corr);
      }
    }
  }
  return out;
}

}  // namespace rs
