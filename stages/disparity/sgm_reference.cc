// Naive SGM: the definition written as plain loops over full int volumes, one path
// direction at a time. Slow and memory-hungry on purpose; it is the oracle for ComputeSgm.
#include <algorithm>
#include <climits>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include "stages/disparity/sgm.h"

namespace rs {
namespace {

uint64_t CensusAt(const cv::Mat& I, int v, int u, int ww, int wh) {
  const int rw = ww / 2, rh = wh / 2;
  const uint8_t c = I.at<uint8_t>(v, u);
  uint64_t code = 0;
  for (int dy = -rh; dy <= rh; ++dy)
    for (int dx = -rw; dx <= rw; ++dx) {
      if (dx == 0 && dy == 0) continue;
      const int y = std::clamp(v + dy, 0, I.rows - 1), x = std::clamp(u + dx, 0, I.cols - 1);
      code = (code << 1) | (I.at<uint8_t>(y, x) < c ? 1u : 0u);
    }
  return code;
}

}  // namespace

SgmOutput ComputeSgmReference(const cv::Mat& L, const cv::Mat& R, const SgmParams& P) {
  if (L.type() != CV_8UC1 || R.type() != CV_8UC1 || L.size() != R.size() || L.empty())
    throw std::invalid_argument("sgm: inputs must be non-empty CV_8UC1 images of equal size");
  P.Check(L.rows);
  const int W = L.cols, H = L.rows, D = P.num_disparities;
  auto idx = [&](int v, int u, int k) { return (static_cast<size_t>(v) * W + u) * D + k; };
  auto offset = [&](int v) { return P.min_disparity + (P.row_offset.empty() ? 0 : P.row_offset[v]); };

  std::vector<int> C(static_cast<size_t>(W) * H * D);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const uint64_t cl = CensusAt(L, v, u, P.census_width, P.census_height);
      for (int k = 0; k < D; ++k) {
        const int x = u - offset(v) - k;
        int cost = P.MaxCost();
        if (x >= 0 && x < W) {
          const uint64_t cr = CensusAt(R, v, x, P.census_width, P.census_height);
          cost = __builtin_popcountll(cl ^ cr);
          const int ad = std::abs(int(L.at<uint8_t>(v, u)) - int(R.at<uint8_t>(v, x)));
          cost += P.ad_weight * std::min(ad, P.ad_truncation);
        }
        C[idx(v, u, k)] = cost;
      }
    }

  std::vector<std::pair<int, int>> dirs = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  if (P.num_paths == 8) dirs.insert(dirs.end(), {{1, 1}, {-1, -1}, {-1, 1}, {1, -1}});
  std::vector<int> S(C.size(), 0), Lr(C.size(), 0);
  for (const auto& [du, dv] : dirs) {
    // Visit order guarantees p - r is done before p.
    for (int vi = 0; vi < H; ++vi) {
      const int v = dv >= 0 ? vi : H - 1 - vi;
      for (int ui = 0; ui < W; ++ui) {
        const int u = du >= 0 ? ui : W - 1 - ui;
        const int pu = u - du, pv = v - dv;
        if (pu < 0 || pu >= W || pv < 0 || pv >= H) {
          for (int k = 0; k < D; ++k) Lr[idx(v, u, k)] = C[idx(v, u, k)];
        } else {
          int p2 = P.p2;
          if (P.adaptive_p2) {
            const int grad = std::abs(int(L.at<uint8_t>(v, u)) - int(L.at<uint8_t>(pv, pu)));
            p2 = std::max(P.p1, P.p2 * P.p2_gradient_scale / (grad + P.p2_gradient_scale));
          }
          int mprev = INT_MAX;
          for (int k = 0; k < D; ++k) mprev = std::min(mprev, Lr[idx(pv, pu, k)]);
          for (int k = 0; k < D; ++k) {
            int best = Lr[idx(pv, pu, k)];
            if (k > 0) best = std::min(best, Lr[idx(pv, pu, k - 1)] + P.p1);
            if (k + 1 < D) best = std::min(best, Lr[idx(pv, pu, k + 1)] + P.p1);
            best = std::min(best, mprev + p2);
            Lr[idx(v, u, k)] = C[idx(v, u, k)] + best - mprev;
          }
        }
      }
    }
    for (size_t i = 0; i < S.size(); ++i) S[i] += Lr[i];
  }

  SgmOutput out;
  out.disparity = cv::Mat::zeros(H, W, CV_32F);
  out.valid = cv::Mat::zeros(H, W, CV_8U);
  for (int v = 0; v < H; ++v) {
    const int off = offset(v);
    std::vector<int> best(W, 0), right_best(W, -1);
    for (int x = 0; x < W; ++x) {
      int bc = INT_MAX;
      for (int k = 0; k < D; ++k) {
        const int u = x + off + k;
        if (u < 0 || u >= W) continue;
        if (S[idx(v, u, k)] < bc) bc = S[idx(v, u, k)], right_best[x] = k;
      }
    }
    for (int u = 0; u < W; ++u) {
      int b = 0;
      for (int k = 1; k < D; ++k)
        if (S[idx(v, u, k)] < S[idx(v, u, b)]) b = k;
      bool ok = true;
      if (P.uniqueness_ratio > 0)
        for (int k = 0; k < D; ++k)
          if (std::abs(k - b) > 1 && S[idx(v, u, k)] * (100 - P.uniqueness_ratio) < S[idx(v, u, b)] * 100) ok = false;
      const int x = u - off - b;
      if (x < 0 || x >= W) ok = false;
      if (ok && P.lr_max_diff >= 0 && (right_best[x] < 0 || std::abs(right_best[x] - b) > P.lr_max_diff)) ok = false;
      if (!ok) continue;
      float sub = 0.0f;
      if (P.subpixel != SubpixelMode::kNone && b > 0 && b < D - 1)
        sub = SubpixelOffset(S[idx(v, u, b - 1)], S[idx(v, u, b)], S[idx(v, u, b + 1)], P.subpixel);
      out.disparity.at<float>(v, u) = static_cast<float>(off + b) + sub;
      out.valid.at<uint8_t>(v, u) = 255;
    }
  }
  return out;
}

}  // namespace rs
