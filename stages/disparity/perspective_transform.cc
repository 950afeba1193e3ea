#include "stages/disparity/perspective_transform.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core/utility.hpp>

namespace rs {

std::vector<double> ComputeGptShift(const RoadModel& road, int width, int height, double delta_px) {
  std::vector<double> kappa(std::max(0, height));
  for (int v = 0; v < height; ++v) kappa[v] = road.RowMin(v, width) - delta_px;
  return kappa;
}

cv::Mat WarpTarget(const cv::Mat& target, const std::vector<double>& kappa) {
  if (target.type() != CV_8UC1 || static_cast<int>(kappa.size()) != target.rows)
    throw std::invalid_argument("gpt: WarpTarget needs a CV_8UC1 image and one kappa per row");
  const int W = target.cols;
  cv::Mat out(target.size(), CV_8UC1);
  cv::parallel_for_(cv::Range(0, target.rows), [&](const cv::Range& rows) {
  for (int v = rows.start; v < rows.end; ++v) {
    const uint8_t* src = target.ptr<uint8_t>(v);
    uint8_t* dst = out.ptr<uint8_t>(v);
    const double fl = std::floor(kappa[v]);
    const int k = static_cast<int>(fl);
    // x = u - kappa = (u - k - 1) + (1 - f): weights fixed along the row, in 1/256 steps.
    const double f = kappa[v] - fl;
    const int wb = static_cast<int>(std::lround(f * 256.0));  // weight of column u - k - 1
    for (int u = 0; u < W; ++u) {
      const int x1 = std::clamp(u - k, 0, W - 1), x0 = std::clamp(u - k - 1, 0, W - 1);
      dst[u] = static_cast<uint8_t>((src[x1] * (256 - wb) + src[x0] * wb + 128) >> 8);
    }
  }
  });
  return out;
}

cv::Mat TrueFromWarpedDisparity(const cv::Mat& l, const cv::Mat& valid, const std::vector<double>& kappa) {
  cv::Mat d = cv::Mat::zeros(l.size(), CV_32F);
  cv::parallel_for_(cv::Range(0, l.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const float* src = l.ptr<float>(v);
      const uint8_t* m = valid.ptr<uint8_t>(v);
      float* dst = d.ptr<float>(v);
      for (int u = 0; u < l.cols; ++u)
        if (m[u]) dst[u] = static_cast<float>(src[u] + kappa[v]);
    }
  });
  return d;
}

void TransformedDisparityRow(const float* src, const uint8_t* m, int width, int v, const RoadModel& road,
                             double delta_px, float* dst) {
  // road(u, v) = a + b u + c u^2 along the row (c = 0 for the planar model).
  const double a = road.c[0] + road.c[2] * v + road.c[5] * v * v, b = road.c[1] + road.c[4] * v, c = road.c[3];
  for (int u = 0; u < width; ++u) dst[u] = m[u] ? static_cast<float>(src[u] - (a + (b + c * u) * u) + delta_px) : 0.0f;
}

cv::Mat TransformedDisparity(const cv::Mat& d, const cv::Mat& valid, const RoadModel& road, double delta_px) {
  cv::Mat t(d.size(), CV_32F);
  cv::parallel_for_(cv::Range(0, d.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v)
      TransformedDisparityRow(d.ptr<float>(v), valid.ptr<uint8_t>(v), d.cols, v, road, delta_px, t.ptr<float>(v));
  });
  return t;
}

}  // namespace rs
