#include "stages/disparity/perspective_transform.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

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

namespace {

// Source column x(u) = u - (a + (b + c u) u) of each target column: floor(x) and the weight of
// floor(x) + 1 in 1/256 steps, rounded half up. In float (16 lanes per AVX-512 vector, twice
// double's): |x| < 2^12 leaves a resolution of 2^-12 px,
// far below the 1/256 weight step. No trapping math: otherwise GCC keeps the float -> int
// conversions scalar (nothing here reads the FP flags).
__attribute__((optimize("no-trapping-math"))) void SourceColumns(double a, double b, double c, int W,
                                                                 int* __restrict col, int* __restrict wgt) {
  const float af = static_cast<float>(a), bf = static_cast<float>(b), cf = static_cast<float>(c);
  for (int u = 0; u < W; ++u) {
    const float uf = static_cast<float>(u);
    const float x = uf - (af + (bf + cf * uf) * uf);
    const float fl = __builtin_floorf(x), hi = static_cast<float>(W);
    col[u] = static_cast<int>(fl < -1.0f ? -1.0f : (fl > hi ? hi : fl));  // the gather's clamps give the same samples
    wgt[u] = static_cast<int>((x - fl) * 256.0f + 0.5f);                  // 0..256
  }
}

// Planar road: x(u) = (X0 + u dX) / 65536 in 16.16 fixed point, the same values as accumulating
// X0 += dX along the row. col is clamped to [-1, W] (the gather's clamps give the same samples).
void PlanarSourceColumns(int64_t X0, int64_t dX, int W, int* __restrict col, int* __restrict wgt) {
  for (int u = 0; u < W; ++u) {
    const int64_t X = X0 + u * dX;
    col[u] = static_cast<int>(std::clamp<int64_t>(X >> 16, -1, W));  // arithmetic shift: floor
    wgt[u] = static_cast<int>(((X & 0xFFFF) + 128) >> 8);            // 0..256
  }
}

// dst(u) = linear interpolation of src between columns col(u) and col(u) + 1 (clamped to the
// image) with weight wgt(u) / 256 on the second. Parameters, not captures, and __restrict: the
// byte stores would otherwise force the width and pointers to be reloaded per pixel.
void GatherRow(const uint8_t* __restrict src, const int* __restrict col, const int* __restrict wgt, int W,
               uint8_t* __restrict dst) {
  for (int u = 0; u < W; ++u) {
    const int x0 = col[u], wb = wgt[u];
    const int i0 = std::clamp(x0, 0, W - 1), i1 = std::clamp(x0 + 1, 0, W - 1);
    dst[u] = static_cast<uint8_t>((src[i0] * (256 - wb) + src[i1] * wb + 128) >> 8);
  }
}

}  // namespace

cv::Mat WarpTargetPerPixel(const cv::Mat& target, const RoadModel& road, double delta_px) {
  if (target.type() != CV_8UC1) throw std::invalid_argument("gpt: WarpTargetPerPixel needs a CV_8UC1 image");
  const int W = target.cols;
  cv::Mat out(target.size(), CV_8UC1);
  cv::parallel_for_(cv::Range(0, target.rows), [&](const cv::Range& rows) {
    std::vector<int> col(W), wgt(W);
    for (int v = rows.start; v < rows.end; ++v) {
      const uint8_t* src = target.ptr<uint8_t>(v);
      uint8_t* dst = out.ptr<uint8_t>(v);
      // s(u) = a + b u + c u^2 along the row.
      const double a = road.c[0] + road.c[2] * v + road.c[5] * v * v - delta_px, b = road.c[1] + road.c[4] * v,
                   c = road.c[3];
      // Source columns and weights first (loops that vectorise), then the gather.
      if (c == 0) {
        // Planar road: the source column x(u) = u (1 - b) - a advances by a constant step, so it is
        // stepped in 16.16 fixed point (drift over a row < 0.01 / 256 px) instead of a floor and a
        // round per pixel.
        PlanarSourceColumns(std::llround(-a * 65536.0), std::llround((1.0 - b) * 65536.0), W, col.data(), wgt.data());
      } else {
        SourceColumns(a, b, c, W, col.data(), wgt.data());
      }
      GatherRow(src, col.data(), wgt.data(), W, dst);
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

void TransformedDisparityRow(const float* __restrict src, const uint8_t* __restrict m, int width, int v,
                             const RoadModel& road, double delta_px, float* __restrict dst) {
  // road(u, v) = a + b u + c u^2 along the row (c = 0 for the planar model).
  const double a = road.c[0] + road.c[2] * v + road.c[5] * v * v, b = road.c[1] + road.c[4] * v, c = road.c[3];
  // A bitwise select instead of a branch on the mask: the loop vectorises.
  for (int u = 0; u < width; ++u) {
    const float t = static_cast<float>(src[u] - (a + (b + c * u) * u) + delta_px);
    dst[u] = std::bit_cast<float>(std::bit_cast<uint32_t>(t) & (0u - static_cast<uint32_t>(m[u] != 0)));
  }
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
