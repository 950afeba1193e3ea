#include "stages/damage/road/relief_smooth.h"

#include "survey/stats/robust_stats.h"

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rs {
namespace {

// Nearest odd integer ≥ 1.
int Odd(double x) { return std::max(1, 2 * static_cast<int>(std::floor(0.5 * x)) + 1); }

}  // namespace

std::vector<double> RoadRowElongation(int rows, const RectifiedStereo& g, const Eigen::Vector3d& n) {
  std::vector<double> out(std::max(0, rows), 1.0);
  // Point where the ray of (u, v) meets the plane, up to the camera height: r / (−n·r) (the
  // camera is on the normal's side, so a ray reaching the road has n·r < 0).
  auto on_road = [&](double u, double v, Eigen::Vector3d* p) {
    const Eigen::Vector3d r((u - g.cx_px) / g.f_px, (v - g.cy_px) / g.f_px, 1.0);
    const double nr = n.dot(r);
    if (!(nr < -1e-9)) return false;
    *p = r / -nr;
    return true;
  };
  for (int v = 0; v < rows; ++v) {
    Eigen::Vector3d up, down, left, right;
    if (!on_road(g.cx_px, v - 0.5, &up) || !on_road(g.cx_px, v + 0.5, &down) || !on_road(g.cx_px - 0.5, v, &left) ||
        !on_road(g.cx_px + 0.5, v, &right))
      continue;
    const double across = (right - left).norm();
    if (!(across > 0)) continue;
    out[v] = std::clamp((down - up).norm() / across, 1.0 / 16, 16.0);
  }
  return out;
}

std::vector<cv::Size> ReliefSmoothWindows(int rows, const RectifiedStereo& g, const Eigen::Vector3d& n, int w,
                                          bool ground) {
  std::vector<cv::Size> out(std::max(0, rows), cv::Size(w, w));
  if (!ground || w <= 1) return out;
  const std::vector<double> e = RoadRowElongation(rows, g, n);
  for (int v = 0; v < rows; ++v) {
    const int height = Odd(w / std::sqrt(e[v]));
    out[v] = cv::Size(Odd(double(w) * w / height), height);
  }
  return out;
}

double SmoothReliefRows(RoadRelief& r, const std::vector<cv::Size>& windows, int row0, double edge_sigma,
                        double noise_px) {
  const int rows = r.depth_below_mm.rows;
  if (row0 < 0 || row0 + rows > static_cast<int>(windows.size()))
    throw std::invalid_argument("SmoothReliefRows: no window for some rows of the relief");
  cv::Mat depth0(r.depth_below_mm.size(), CV_32F);  // depth with invalid (NaN) = 0
  tbb::parallel_for(0, depth0.rows, [&](int v) {
    const float* x = r.depth_below_mm.ptr<float>(v);
    float* y = depth0.ptr<float>(v);
    for (int u = 0; u < depth0.cols; ++u) y[u] = std::isnan(x[u]) ? 0.0f : x[u];
  });
  // Bands of rows sharing a window. Valid-pixel counts are summed on the 0/255 mask itself
  // (integer sums: exactly 255 × count, divided back below).
  struct Band {
    int v0, v1;
    cv::Size k;
  };
  std::vector<Band> bands;
  for (int v = 0; v < rows; ++v) {
    const cv::Size k = windows[row0 + v];
    if (bands.empty() || bands.back().k != k)
      bands.push_back({v, v + 1, k});
    else
      bands.back().v1 = v + 1;
  }
  cv::Mat wsum, dsum, tsum;
  const cv::Mat* src[3] = {&r.valid_mask, &depth0, &r.transformed_disparity_px};
  cv::Mat* dst[3] = {&wsum, &dsum, &tsum};
  if (bands.size() <= 1) {
    // One window: the whole frame at once (each sum single-threaded in OpenCV: side by side).
    const cv::Size k = bands.empty() ? cv::Size(1, 1) : bands[0].k;
    tbb::parallel_for(0, 3, [&](int i) {
      cv::boxFilter(*src[i], *dst[i], CV_32F, k, {-1, -1}, false, cv::BORDER_CONSTANT);
    });
  } else {
    for (cv::Mat* d : dst) d->create(r.depth_below_mm.size(), CV_32F);
    // Each band filtered with the rows its window reaches beyond it (outside the image: zero,
    // as the full-frame filter), written to its own rows: a row range without BORDER_ISOLATED
    // reads the rows beyond it from its image (the same sums, in the same order, as filtering
    // the extended range and copying the band's rows out). Headers on the pixels alone, so a
    // relief that is a view (RefineRoadRelief's masks) reads nothing beyond itself.
    tbb::parallel_for(0, static_cast<int>(3 * bands.size()), [&](int job) {
      const Band& b = bands[job / 3];
      const int i = job % 3;
      const cv::Mat in(src[i]->rows, src[i]->cols, src[i]->type(), src[i]->data, src[i]->step);
      cv::Mat out = dst[i]->rowRange(b.v0, b.v1);  // a view: the filter writes the band in place
      cv::boxFilter(in.rowRange(b.v0, b.v1), out, CV_32F, b.k, {-1, -1}, false, cv::BORDER_CONSTANT);
    });
  }
  double sigma = 0;
  if (edge_sigma > 0) {
    sigma = noise_px;
    if (!(sigma > 0)) {
      std::vector<float> dev;
      for (int v = 0; v < rows; v += 4) {
        const uchar* va = r.valid_mask.ptr<uchar>(v);
        const float* ws = wsum.ptr<float>(v);
        const float* ts = tsum.ptr<float>(v);
        const float* td = r.transformed_disparity_px.ptr<float>(v);
        for (int u = 0; u < r.depth_below_mm.cols; u += 4)
          if (va[u]) dev.push_back(std::abs(td[u] - std::max(1e-3f, ts[u] * 255.0f / ws[u])));
      }
      if (!dev.empty()) sigma = RobustSigmaOfAbs(dev);
      sigma = std::max(sigma, 1e-4);  // quantised (truth) disparities: not below 1/10000 px
    }
  }
  const float limit = static_cast<float>(edge_sigma * sigma);
  tbb::parallel_for(0, rows, [&](int v) {
    const uchar* va = r.valid_mask.ptr<uchar>(v);
    const float* ws = wsum.ptr<float>(v);
    const float* ds = dsum.ptr<float>(v);
    const float* ts = tsum.ptr<float>(v);
    float* db = r.depth_below_mm.ptr<float>(v);
    float* td = r.transformed_disparity_px.ptr<float>(v);
    // Branch-free (every quotient computed, the pixel's own values kept by a select), so the
    // compiler vectorises the divisions; the same values as skipping.
    const int cols = r.depth_below_mm.cols;
    const float lim = limit;  // locals: the stores below could alias what the lambda captures
    for (int u = 0; u < cols; ++u) {
      const float n = ws[u] / 255.0f;  // exact: ws = 255 × count
      const float q = ts[u] / n;
      const float t = 1e-3f < q ? q : 1e-3f;  // std::max(1e-3f, q): valid stays > 0
      // Invalid pixels stay NaN / 0; a step keeps its own values.
      const bool keep = (va[u] == 0) | ((lim > 0) & (std::abs(td[u] - t) > lim));
      const float dq = ds[u] / n;
      db[u] = keep ? db[u] : dq;
      td[u] = keep ? td[u] : t;
    }
  });
  return sigma;
}

}  // namespace rs
