#include "stages/damage/noise/scale_noise.h"

#include "stages/damage/noise/two_sided_noise.h"

#include "survey/stats/order_statistic.h"
#include "survey/stats/robust_stats.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace rs {

ScaleNoise MeasureScaleNoise(const cv::Mat& depth_below_mm, const cv::Mat& road, const cv::Mat& labels, int id,
                             const cv::Rect& box, int window_px, int margin_px, double spike_quantile,
                             double floor_sigma_mm) {
  if (depth_below_mm.type() != CV_32FC1 || road.type() != CV_8UC1 || labels.type() != CV_16UC1 ||
      road.size() != depth_below_mm.size() || labels.size() != depth_below_mm.size())
    throw std::invalid_argument("MeasureScaleNoise: depth CV_32F, road CV_8U, labels CV_16U of one size needed");
  if (window_px < 1 || box.empty() || margin_px < 0 || !(spike_quantile > 0 && spike_quantile < 1) ||
      !(floor_sigma_mm >= 0))
    throw std::invalid_argument(
        "MeasureScaleNoise: window_px >= 1, a non-empty box, margin_px >= 0, 0 < spike_quantile < 1, floor >= 0 "
        "needed");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ScaleNoise out;
  out.window_px = window_px;
  const cv::Rect roi =
      cv::Rect(box.x - margin_px, box.y - margin_px, box.width + 2 * margin_px, box.height + 2 * margin_px) &
      cv::Rect({}, depth_below_mm.size());
  // Window sums of the measured depth and of the measured-pixel count (zero outside the frame).
  cv::Mat x(roi.size(), CV_32F), m(roi.size(), CV_32F);
  for (int v = 0; v < roi.height; ++v) {
    const float* d = depth_below_mm.ptr<float>(roi.y + v) + roi.x;
    const uchar* r = road.ptr<uchar>(roi.y + v) + roi.x;
    float* xv = x.ptr<float>(v);
    float* mv = m.ptr<float>(v);
    for (int u = 0; u < roi.width; ++u) {
      const bool ok = r[u] && std::isfinite(d[u]);
      xv[u] = ok ? d[u] : 0.0f;
      mv[u] = ok ? 1.0f : 0.0f;
    }
  }
  const cv::Size k(window_px, window_px);
  cv::Mat sx, sm;
  cv::boxFilter(x, sx, CV_32F, k, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::boxFilter(m, sm, CV_32F, k, {-1, -1}, false, cv::BORDER_CONSTANT);
  const float min_count = 0.5f * window_px * window_px;
  const cv::Mat own = labels(roi) == id;
  cv::Mat own_grown;
  cv::dilate(own, own_grown,
             cv::getStructuringElement(cv::MORPH_RECT, {2 * (window_px / 2) + 1, 2 * (window_px / 2) + 1}));
  double deepest = -std::numeric_limits<double>::infinity();
  std::vector<float> up, down;
  for (int v = 0; v < roi.height; ++v) {
    const float* s = sx.ptr<float>(v);
    const float* c = sm.ptr<float>(v);
    const float* mv = m.ptr<float>(v);
    const uchar* o = own.ptr<uchar>(v);
    const uchar* g = own_grown.ptr<uchar>(v);
    for (int u = 0; u < roi.width; ++u) {
      if (c[u] < min_count) continue;
      const float mean = s[u] / c[u];
      if (o[u]) {
        deepest = std::max(deepest, double(mean));
      } else if (!g[u] && mv[u] && ((u | v) & 1) == 0) {  // every second pixel: ample samples
        if (mean > 0)
          down.push_back(mean);
        else if (mean < 0)
          up.push_back(-mean);
      }
    }
  }
  out.depth_mm = std::isfinite(deepest) ? deepest : nan;
  out.samples = static_cast<int>(up.size() + down.size());
  if (up.size() < 50 || down.size() < 50) {
    out.sigma_mm = out.spike_mm = nan;
    return out;
  }
  // The spike quantile's rank rounds to nearest (LocalReliefSpikes' rounds down).
  out.spike_mm = KthSmallestInPlace(up, QuantileRankNearest(spike_quantile, up.size()));
  const double sigma_up = SigmaOfOneSidedMedian(LowerMedianInPlace(up));
  const double sigma_down = SigmaOfOneSidedMedian(LowerMedianInPlace(down));
  out.sigma_mm = std::max(floor_sigma_mm, TwoSidedSigma(sigma_up, sigma_down, kMatchingNoiseMaxAsymmetry));
  return out;
}

}  // namespace rs
