#include "stages/disparity/disparity.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include "stages/disparity/perspective_transform.h"
#include "survey/elapsed.h"

namespace rs {
namespace {

std::string Num(double x) {
  std::string s = std::to_string(x);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

// Road model from a dense disparity map (plain SGM path): a grid of valid samples.
RoadModel FitFromDense(const cv::Mat& d, const cv::Mat& valid, const RoadFitOptions& o, const RoadModel* prior) {
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(d.total()) / 4000.0)));
  std::vector<DisparitySample> s;
  for (int v = step / 2; v < d.rows; v += step)
    for (int u = step / 2; u < d.cols; u += step)
      if (valid.at<uint8_t>(v, u)) s.push_back({double(u), double(v), double(d.at<float>(v, u))});
  return FitRoadModel(s, d.cols, d.rows, o, prior);
}

// Gaussian pre-smoothing before the census (0 = the image itself).
cv::Mat Presmooth(const cv::Mat& image, double sigma_px) {
  if (!(sigma_px > 0)) return image;
  cv::Mat out;
  cv::GaussianBlur(image, out, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace

void DisparityParams::Check() const {
  auto fail = [](const std::string& field, const std::string& value, const std::string& rule) {
    throw std::invalid_argument("disparity." + field + " = " + value + " violates " + rule);
  };
  if (num_disparities < 1 || num_disparities > 1024)
    fail("num_disparities", std::to_string(num_disparities), "1 <= num_disparities <= 1024");
  if (p2 <= p1) fail("p2", std::to_string(p2), "p2 > p1 (p1 = " + std::to_string(p1) + ")");
  if (gpt_num_disparities < 2 || gpt_num_disparities > 1024)
    fail("gpt_num_disparities", std::to_string(gpt_num_disparities), "2 <= gpt_num_disparities <= 1024");
  if (!(gpt_delta_px >= 0) || !(gpt_delta_px < gpt_num_disparities))
    fail("gpt_delta_px", Num(gpt_delta_px),
         "0 <= gpt_delta_px < gpt_num_disparities (" + std::to_string(gpt_num_disparities) + ")");
  if (!(gpt_headroom_px >= 0)) fail("gpt_headroom_px", Num(gpt_headroom_px), "gpt_headroom_px >= 0");
  if (fill_min_neighbours < 0 || fill_min_neighbours > 8)
    fail("fill_min_neighbours", std::to_string(fill_min_neighbours), "0 <= fill_min_neighbours <= 8");
  if (refine_window < 0 || (refine_window > 0 && refine_window % 2 == 0) || refine_window > 31)
    fail("refine_window", std::to_string(refine_window), "refine_window = 0 or odd, <= 31");
  if (refine_smooth_window < 0 || (refine_smooth_window > 0 && refine_smooth_window % 2 == 0) ||
      refine_smooth_window > 63)
    fail("refine_smooth_window", std::to_string(refine_smooth_window), "refine_smooth_window = 0 or odd, <= 63");
  if (!(refine_smooth_agree_px >= 0))
    fail("refine_smooth_agree_px", Num(refine_smooth_agree_px), "refine_smooth_agree_px >= 0");
  if (refine_highpass_px < 3 || refine_highpass_px % 2 == 0 || refine_highpass_px > 63)
    fail("refine_highpass_px", std::to_string(refine_highpass_px),
         "refine_highpass_px odd, 3 <= refine_highpass_px <= 63");
  if (!(refine_max_coherence > 0 && refine_max_coherence <= 1))
    fail("refine_max_coherence", Num(refine_max_coherence), "0 < refine_max_coherence <= 1");
  if (!(refine_shift_ratio == 0 || refine_shift_ratio >= 1))
    fail("refine_shift_ratio", Num(refine_shift_ratio), "refine_shift_ratio = 0 or >= 1");
  if (speckle_window_size < 0)
    fail("speckle_window_size", std::to_string(speckle_window_size), "speckle_window_size >= 0");
  if (!(gpt_min_valid_fraction >= 0 && gpt_min_valid_fraction <= 1))
    fail("gpt_min_valid_fraction", Num(gpt_min_valid_fraction), "0 <= gpt_min_valid_fraction <= 1");
  if (!(speckle_max_diff_px >= 0)) fail("speckle_max_diff_px", Num(speckle_max_diff_px), "speckle_max_diff_px >= 0");
  if (!(max_road_tilt_deg >= 0 && max_road_tilt_deg <= 90))
    fail("max_road_tilt_deg", Num(max_road_tilt_deg), "0 <= max_road_tilt_deg <= 90");
  try {
    ToSgm(min_disparity, num_disparities).Check(0);
    road.Check();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("disparity.") + e.what());
  }
}

SgmParams DisparityParams::ToSgm(int min_d, int num_d) const {
  SgmParams s;
  s.census_width = census_width, s.census_height = census_height;
  s.ad_weight = ad_weight, s.ad_truncation = ad_truncation;
  s.num_paths = num_paths, s.p1 = p1, s.p2 = p2, s.adaptive_p2 = adaptive_p2, s.p2_gradient_scale = p2_gradient_scale;
  s.min_disparity = min_d, s.num_disparities = num_d;
  s.uniqueness_ratio = uniqueness_ratio, s.subpixel = subpixel, s.lr_max_diff = lr_max_diff;
  return s;
}

namespace {

// t where keep, else +0, as a bitwise select: no branch, so per-pixel loops using it vectorise.
inline float KeepOrZero(float t, bool keep) {
  return std::bit_cast<float>(std::bit_cast<uint32_t>(t) & (0u - static_cast<uint32_t>(keep)));
}

// FilterSpeckles' 1/16-px fixed-point row (INT16_MIN where invalid). nearbyint rounds like
// cvRound (to nearest even) but vectorises; disparities are finite, far inside the clamp range.
void ToFixedRow(const float* __restrict d, const uint8_t* __restrict m, int W, int16_t* __restrict f) {
  for (int u = 0; u < W; ++u) {
    const int16_t x = static_cast<int16_t>(std::clamp(std::nearbyint(d[u] * 16.0f), -32000.0f, 32000.0f));
    f[u] = m[u] ? x : int16_t{INT16_MIN};
  }
}

// Run codes of a fixed-point row: 0 = pixel u joins the run of u - 1 (both valid, step <=
// max_diff), 1 = valid and starts a run, 2 = invalid. Written branch-free (vectorises); the 8
// bytes after the row are set to 1 so that word-wise scans stop at the row end.
void RunBreaksRow(const int16_t* __restrict f, int W, int max_diff, uint8_t* __restrict brk) {
  constexpr int16_t kInvalid = INT16_MIN;
  brk[0] = f[0] == kInvalid ? 2 : 1;
  for (int u = 1; u < W; ++u) {
    const bool invalid = f[u] == kInvalid;
    const bool joined = (f[u - 1] != kInvalid) & (std::abs(f[u] - f[u - 1]) <= max_diff);
    brk[u] = static_cast<uint8_t>(invalid ? 2 : (joined ? 0 : 1));
  }
  std::fill(brk + W, brk + W + 8, uint8_t{1});
}

// Per-row steps of ComputeDisparity's final pass. Bitwise selects instead of branches, and
// __restrict parameters (the byte mask could alias the disparities as far as GCC knows): the
// loops vectorise, a few ms per frame less than scalar ones.

// After a per-pixel warp: true d = l + a + (b + c x) x at the matched column x = u - l.
void PixelWarpToTrueRow(float* __restrict d, const uint8_t* __restrict m, int W, double a, double b, double c) {
  for (int u = 0; u < W; ++u) {
    const float l = d[u];
    const double x = u - l;
    d[u] = KeepOrZero(static_cast<float>(l + a + (b + c * x) * x), m[u] != 0);
  }
}

// After a per-row warp: true d = l + kappa.
void RowWarpToTrueRow(float* __restrict d, const uint8_t* __restrict m, int W, double kappa) {
  for (int u = 0; u < W; ++u) d[u] = KeepOrZero(static_cast<float>(d[u] + kappa), m[u] != 0);
}

// Drops matches outside the target image (u - d not in [0, W - 1]); returns the valid count.
int DropOutsideRow(float* __restrict d, uint8_t* __restrict m, int W) {
  int n_valid = 0;
  const float last = static_cast<float>(W - 1);
  for (int u = 0; u < W; ++u) {
    const float x = u - d[u];
    const bool was = m[u] != 0, keep = was & !(x < 0) & !(x > last);
    d[u] = KeepOrZero(d[u], keep | !was);
    m[u] = m[u] & static_cast<uint8_t>(0 - static_cast<int>(keep));
    n_valid += keep;
  }
  return n_valid;
}

}  // namespace

void FilterSpeckles(cv::Mat* disparity, cv::Mat* valid, int max_size, double max_diff_px) {
  if (max_size <= 0) return;
  // Same definition as OpenCV's filterSpeckles on a 1/16-px fixed-point copy: the connected
  // components of the graph joining 4-neighbours that are both valid and differ by at most
  // max_diff (fixed point); components of at most max_size pixels are dropped. Worked on runs
  // (maximal horizontally joined segments of a row, found row-parallel) joined by union-find
  // across rows: a dense disparity map has a few runs per row, so this costs one pass over the
  // pixels instead of a per-pixel flood fill with a label image.
  const int H = disparity->rows, W = disparity->cols, max_diff = cvRound(max_diff_px * 16.0);
  struct Run {
    int begin, end;  // columns [begin, end)
  };
  thread_local cv::Mat tls_fixed;  // reused: fresh buffers per frame cost page faults
  thread_local std::vector<std::vector<Run>> tls_runs;
  cv::Mat& fixed = tls_fixed;
  std::vector<std::vector<Run>>& runs = tls_runs;
  fixed.create(H, W, CV_16S);
  runs.resize(H);
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    std::vector<uint8_t> brk(W + 8);  // RunBreaksRow's codes, 8 bytes of slack for word reads
    for (int v = r.begin(); v < r.end(); ++v) {
      const float* d = disparity->ptr<float>(v);
      const uint8_t* m = valid->ptr<uint8_t>(v);
      int16_t* f = fixed.ptr<int16_t>(v);
      ToFixedRow(d, m, W, f);
      RunBreaksRow(f, W, max_diff, brk.data());
      std::vector<Run>& row = runs[v];
      row.clear();
      for (int u = 0; u < W;) {
        if (brk[u] == 2) {  // invalid
          ++u;
          continue;
        }
        const int begin = u;
        // The run goes on to the next nonzero code, 8 codes per step (the slack reads as "break").
        for (++u; u < W; u += 8) {
          uint64_t word;
          std::memcpy(&word, brk.data() + u, sizeof(word));
          if (word) {
            u += std::countr_zero(word) / 8;
            break;
          }
        }
        u = std::min(u, W);
        row.push_back({begin, u});
      }
    }
  });
  std::vector<int> first(H + 1, 0);  // global id of each row's first run
  for (int v = 0; v < H; ++v) first[v + 1] = first[v] + static_cast<int>(runs[v].size());
  std::vector<int> parent(first[H]), size(first[H]);
  for (int v = 0; v < H; ++v)
    for (size_t k = 0; k < runs[v].size(); ++k)
      parent[first[v] + k] = first[v] + static_cast<int>(k), size[first[v] + k] = runs[v][k].end - runs[v][k].begin;
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  // Overlapping runs of consecutive rows join where any shared column is a vertical edge; both
  // runs' pixels are valid there. The overlaps of a row pair tile at most W columns, so the scans
  // stay linear in the pixels.
  for (int v = 1; v < H; ++v) {
    const std::vector<Run>&A = runs[v - 1], &B = runs[v];
    const int16_t *fa = fixed.ptr<int16_t>(v - 1), *fb = fixed.ptr<int16_t>(v);
    size_t i = 0, j = 0;
    while (i < A.size() && j < B.size()) {
      const int lo = std::max(A[i].begin, B[j].begin), hi = std::min(A[i].end, B[j].end);
      if (lo < hi) {
        int a = find(first[v - 1] + static_cast<int>(i)), b = find(first[v] + static_cast<int>(j));
        if (a != b)
          for (int u = lo; u < hi; ++u)
            if (std::abs(fa[u] - fb[u]) <= max_diff) {
              if (b < a) std::swap(a, b);
              parent[b] = a, size[a] += size[b];
              break;
            }
      }
      if (A[i].end <= B[j].end)
        ++i;
      else
        ++j;
    }
  }
  std::vector<uint8_t> drop(parent.size());
  for (size_t k = 0; k < parent.size(); ++k) drop[k] = size[find(static_cast<int>(k))] <= max_size;
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      float* d = disparity->ptr<float>(v);
      uint8_t* m = valid->ptr<uint8_t>(v);
      int u = 0;  // invalid pixels between runs get disparity 0 as well
      for (size_t k = 0; k < runs[v].size(); ++k) {
        const Run& run = runs[v][k];
        std::fill(d + u, d + run.begin, 0.0f);
        u = run.end;
        if (!drop[first[v] + k]) continue;
        std::fill(d + run.begin, d + run.end, 0.0f);
        std::fill(m + run.begin, m + run.end, uint8_t{0});
      }
      std::fill(d + u, d + W, 0.0f);
    }
  });
}

namespace {

using vf = float __attribute__((vector_size(64)));  // 16 floats (one AVX-512 register, two AVX2)
constexpr int kFloats = 16;

inline void Sort2(vf& a, vf& b) {
  const vf lo = a < b ? a : b, hi = a < b ? b : a;
  a = lo, b = hi;
}

// The same 19-exchange network as Median9, on 16 pixels at once.
inline vf Median9(vf* p) {
  Sort2(p[1], p[2]), Sort2(p[4], p[5]), Sort2(p[7], p[8]), Sort2(p[0], p[1]), Sort2(p[3], p[4]);
  Sort2(p[6], p[7]), Sort2(p[1], p[2]), Sort2(p[4], p[5]), Sort2(p[7], p[8]), Sort2(p[0], p[3]);
  Sort2(p[5], p[8]), Sort2(p[4], p[7]), Sort2(p[3], p[6]), Sort2(p[1], p[4]), Sort2(p[2], p[5]);
  Sort2(p[4], p[7]), Sort2(p[4], p[2]), Sort2(p[6], p[4]), Sort2(p[4], p[2]);
  return p[4];
}

}  // namespace

void MedianValid3x3(cv::Mat* disparity, const cv::Mat& valid) {
  thread_local cv::Mat tls_src;  // reused: a fresh copy per frame costs page faults
  cv::Mat& src = tls_src;
  disparity->copyTo(src);
  const int W = src.cols, H = src.rows;
  using vi = int32_t __attribute__((vector_size(4 * kFloats)));
  using vb = uint8_t __attribute__((vector_size(kFloats)));
  constexpr float kInf = std::numeric_limits<float>::infinity();
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    float vals[9];
    const std::vector<uint8_t> no_valid(W, 0);  // the row beyond the image border
    const std::vector<float> no_value(W, 0.0f);
    for (int v = r.begin(); v < r.end(); ++v) {
      const uint8_t* mrow[3] = {v > 0 ? valid.ptr<uint8_t>(v - 1) : no_valid.data(), valid.ptr<uint8_t>(v),
                                v + 1 < H ? valid.ptr<uint8_t>(v + 1) : no_valid.data()};
      const float* srow[3] = {v > 0 ? src.ptr<float>(v - 1) : no_value.data(), src.ptr<float>(v),
                              v + 1 < H ? src.ptr<float>(v + 1) : no_value.data()};
      const uint8_t* m = mrow[1];
      float* dst = disparity->ptr<float>(v);
      auto general = [&](int u) {  // scalar: image borders and the row tail
        int n = 0;
        for (int y = 0; y < 3; ++y)
          for (int x = std::max(0, u - 1); x <= std::min(W - 1, u + 1); ++x)
            if (mrow[y][x]) vals[n++] = srow[y][x];
        for (int a = 1; a < n; ++a)  // insertion sort of at most 9 values
          for (int b = a; b > 0 && vals[b] < vals[b - 1]; --b) std::swap(vals[b], vals[b - 1]);
        dst[u] = vals[(n - 1) / 2];
      };
      int u = 0;
      if (m[0]) general(0);
      // 16 pixels at once. The lower median of the n valid neighbours is the plain median of 9
      // once the 9 - n invalid ones are replaced by k = 4 - (n - 1) / 2 times -inf and the rest
      // +inf (k values sort below the n valid ones, and 4 - k = (n - 1) / 2).
      for (u = 1; u + kFloats <= W - 1; u += kFloats) {
        vf p[9];
        vb b[9], any_invalid = vb{};
        for (int y = 0; y < 3; ++y)
          for (int dx = 0; dx < 3; ++dx) {
            std::memcpy(&p[3 * y + dx], srow[y] + u - 1 + dx, sizeof(vf));
            std::memcpy(&b[3 * y + dx], mrow[y] + u - 1 + dx, sizeof(vb));
            any_invalid |= reinterpret_cast<vb>(b[3 * y + dx] == 0);
          }
        uint64_t flags[2];
        std::memcpy(flags, &any_invalid, sizeof(flags));
        if ((flags[0] | flags[1]) == 0) {  // all 9 neighbours of all 16 pixels valid: the common case
          const vf md = Median9(p);
          std::memcpy(dst + u, &md, sizeof(md));
          continue;
        }
        vi ok[9], n = vi{};
        for (int q = 0; q < 9; ++q) ok[q] = __builtin_convertvector(b[q], vi) != 0, n -= ok[q];
        const vi k = 4 - (n - 1) / 2;
        vi low = vi{};  // invalid neighbours replaced so far
        for (int q = 0; q < 9; ++q) {
          const vf pad = low < k ? vf{} - kInf : vf{} + kInf;
          p[q] = ok[q] ? p[q] : pad;
          low += ok[q] ? 0 : 1;
        }
        const vf md = Median9(p);
        vf old;
        std::memcpy(&old, dst + u, sizeof(old));
        const vf out = ok[4] ? md : old;  // ok[4]: the centre pixel
        std::memcpy(dst + u, &out, sizeof(out));
      }
      for (; u < W; ++u)
        if (m[u]) general(u);
    }
  });
}

namespace {

// img minus its local mean (box of `box` px), CV_16S.
void HighPass(const cv::Mat& img, int box, cv::Mat* out) {
  thread_local cv::Mat tls_mean;
  cv::blur(img, tls_mean, cv::Size(box, box), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  cv::subtract(img, tls_mean, *out, cv::noArray(), CV_16S);
}

// RefineSubpixel's per-pixel terms: num = k G^2 - 24 e G, den = G^2 (both 0 when |24 e G| > G^2) for the
// pixels [u0, u0 + n) of a row, all with the integer disparity k and T already offset by -k
// (Tk[u] = T[u - k]); 0 where invalid. In a function of its own with __restrict pointers and a
// loop-invariant k, the loads are contiguous and the loop vectorises.
// With kFit: also fit[u] = G^2 (k_n - e_n / G_n - c)^2 = (kc G - 24 e)^2 (kc = k - c), the pixel's
// share of the window's squared residual about the offset c (see RefineFit).
template <bool kFit>
__attribute__((noinline)) void RefineTerms(const int16_t* __restrict L, const int16_t* __restrict Tk,
                                           const uint8_t* __restrict m, int k, int u0, int n, float* __restrict num,
                                           float* __restrict den, int kc, float* __restrict fit) {
  for (int u = u0; u < u0 + n; ++u) {
    // 24 x the mean of both views' derivatives: the derivative at the midpoint of the step, so
    // one Gauss-Newton step is exact for quadratic intensity profiles (efficient second-order
    // minimisation), each by the 5-tap difference (8 (I+1 - I-1) - (I+2 - I-2)) / 12 (central
    // differences underestimate the slope of fine texture by sin(w)/w and the step overshoots).
    const int g =
        8 * (Tk[u + 1] - Tk[u - 1]) - (Tk[u + 2] - Tk[u - 2]) + 8 * (L[u + 1] - L[u - 1]) - (L[u + 2] - L[u - 2]);
    const int e = L[u] - Tk[u];
    const int g2 = g * g;
    // The pixel's step is 24 e G / G^2; one beyond 1 px means SGM's winner there is off by a
    // pixel or more (the inside edge of a painted line, an occlusion), and the pixel is left out.
    const int eg = 24 * e * g;
    // A 0/1 weight in int lanes and a multiply, not a branch or a bool: the loop vectorises.
    const int ok = static_cast<int>(m[u]) * static_cast<int>(eg <= g2) * static_cast<int>(eg >= -g2);
    const float w = static_cast<float>(ok != 0);
    num[u] = w * (static_cast<float>(k) * static_cast<float>(g2) - static_cast<float>(eg));
    den[u] = w * static_cast<float>(g2);
    if constexpr (kFit) {
      const float r = static_cast<float>(kc) * static_cast<float>(g) - static_cast<float>(24 * e);
      fit[u] = w * r * r;
    }
  }
}

// One row of terms: runs of pixels sharing one integer disparity (long ones after the per-pixel
// warp: the road's residual is delta everywhere) go to RefineTerms whole, the run's ends that
// would read outside either image get no terms.
void RefineTermsRow(const int16_t* L, const int16_t* T, const uint8_t* m, const float* d, int W, int* k_row, float* num,
                    float* den, int c = 0, float* fit = nullptr) {
  for (int u = 0; u < W; ++u) k_row[u] = static_cast<int>(std::nearbyint(d[u]));
  for (int u0 = 0; u0 < W;) {
    const int k = k_row[u0];
    int u1 = u0 + 1;
    while (u1 < W && k_row[u1] == k) ++u1;
    // Inside both images with the 5-tap neighbourhoods: u in [2, W - 3] and u - k in [2, W - 3].
    const int lo = std::max({u0, 2, 2 + k}), hi = std::min({u1, W - 2, W - 2 + k});
    for (int u = u0; u < std::min(lo, u1); ++u) num[u] = 0, den[u] = 0;
    if (fit) {
      for (int u = u0; u < std::min(lo, u1); ++u) fit[u] = 0;
      for (int u = std::max(hi, u0); u < u1; ++u) fit[u] = 0;
      if (lo < hi) RefineTerms<true>(L, T - k, m, k, lo, hi - lo, num, den, k - c, fit);
    } else if (lo < hi) {
      RefineTerms<false>(L, T - k, m, k, lo, hi - lo, num, den, 0, nullptr);
    }
    for (int u = std::max(hi, u0); u < u1; ++u) num[u] = 0, den[u] = 0;
    u0 = u1;
  }
}

// RefineSubpixel's last step for one row: l = num / den where valid, textured enough and within
// 1 px of SGM's value `d`; else d.
void RefineApplyRow(const float* __restrict sum_n, const float* __restrict sum_d, const uint8_t* __restrict m, int W,
                    float min_weight, const float* __restrict d, float* __restrict out) {
  for (int u = 0; u < W; ++u) {
    const float l = sum_n[u] / std::max(sum_d[u], 1.0f);
    const bool take = (m[u] != 0) & (sum_d[u] >= min_weight) & (std::abs(l - d[u]) <= 1.0f);
    out[u] = take ? l : d[u];
  }
}

// acc[u] = sum of col[u + t], t in [-r, r] (col readable there). A window of 3m pixels (9, 21) as
// m sums of three: 2 + (m - 1) vector adds per pixel instead of 3m - 1 (the 21-px smooth pass).
void BoxRow(const float* __restrict col, int W, int r, float* __restrict acc) {
  const int window = 2 * r + 1;
  if (window % 3 != 0 || window < 9) {
    std::fill(acc, acc + W, 0.0f);
    for (int t = -r; t <= r; ++t)
      for (int u = 0; u < W; ++u) acc[u] += col[u + t];
    return;
  }
  // s3[i] = col[i - 1] + col[i] + col[i + 1] for i in [-r + 1, W + r - 1).
  thread_local std::vector<float> tls_s3;
  tls_s3.resize(static_cast<size_t>(W + 2 * r));
  float* __restrict s3 = tls_s3.data() + r;
  for (int i = -r + 1; i < W + r - 1; ++i) s3[i] = col[i - 1] + col[i] + col[i + 1];
  std::fill(acc, acc + W, 0.0f);
  for (int t = -r + 1; t <= r - 1; t += 3)
    for (int u = 0; u < W; ++u) acc[u] += s3[u + t];
}

// col[u] += sign * row[u].
void AddRow(const float* __restrict row, int W, float sign, float* __restrict col) {
  for (int u = 0; u < W; ++u) col[u] += sign * row[u];
}

// Agreement the smooth window's value needs with the small window's (see RefineSubpixel), from the
// small window's sum of G^2, squared: max(agree_px, kAgreeScale / sqrt(sum))^2 in 1/10000 px^2,
// capped at 6.5 px^2 (uint16; no square root, so the loop vectorises).
constexpr float kAgreeScale = 60.0f;
void AgreeRow(const float* __restrict sum_d, int W, float agree_px, uint16_t* __restrict out) {
  const float a2 = agree_px * agree_px, c2 = kAgreeScale * kAgreeScale;
  for (int u = 0; u < W; ++u) {
    const float t2 = std::max(a2, c2 / std::max(sum_d[u], 1.0f));
    out[u] = static_cast<uint16_t>(static_cast<int>(std::min(65000.0f, t2 * 10000.0f)));  // truncation: never looser
  }
}

// A refinement window's fit, per pixel (RefinePass with a RefineFit): `value` = its least-squares
// shift (unconditional), `spread` = the G^2-weighted variance of its pixels' own estimates about
// it, px^2 (the fit's residual over sum G^2: noise, plus the square of any disparity step the
// window straddles), +inf where the window's sum G^2 is below the pass's gate.
struct RefineFit {
  cv::Mat value, spread;
};

// RefineFit's row from the window sums about the offset c: spread = sum fit / sum G^2 - (l - c)^2.
void FitRow(const float* __restrict sum_n, const float* __restrict sum_d, const float* __restrict sum_f, int W, int c,
            float min_weight, float* __restrict value, float* __restrict spread) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const float cf = static_cast<float>(c);
  for (int u = 0; u < W; ++u) {
    const float inv = 1.0f / std::max(sum_d[u], 1.0f);
    const float l = sum_n[u] * inv, lc = l - cf;
    value[u] = l;
    spread[u] = sum_d[u] >= min_weight ? std::max(0.0f, sum_f[u] * inv - lc * lc) : kInf;
  }
}

// One refinement pass over the whole map `sgm` (SGM's values; their integer parts are the winners)
// with a window x window window (see RefineSubpixel) into `out` (another Mat: no copy of `sgm`).
// `terms`: the pixels whose intensities enter the sums (valid ones, possibly fewer); `valid`: the
// pixels refined. `agree` (optional): AgreeRow of this pass's sums, for the smooth window's merge.
// `fit` (optional): the window's RefineFit at every pixel, for ShiftWindows.
void RefinePass(const cv::Mat& ref_hp, const cv::Mat& target_hp, const cv::Mat& sgm, cv::Mat* out, const cv::Mat& valid,
                const cv::Mat& terms, int window, float min_weight, cv::Mat* agree = nullptr, float agree_px = 0,
                RefineFit* fit = nullptr, const std::vector<int>* window_rows = nullptr) {
  const int W = ref_hp.cols, H = ref_hp.rows, rh = window / 2;  // rh: the window's half-width
  // Bands of rows, each on its own: the terms of the band's rows and r rows either side (the
  // window's reach; recomputed by both neighbouring bands — cheaper than a second parallel pass
  // over full-size maps), column sums sliding down the band, then each row's horizontal sums.
  constexpr int kBand = 96;          // the 21-px window's 20 halo rows cost 21 % of a band's terms
  CV_Assert(out->data != sgm.data);  // a band's halo rows are its neighbours' output rows
  out->create(sgm.size(), CV_32F);
  if (agree) agree->create(sgm.size(), CV_16U);
  if (fit) fit->value.create(sgm.size(), CV_32F), fit->spread.create(sgm.size(), CV_32F);
  tbb::parallel_for(tbb::blocked_range<int>(0, H, kBand), [&](const tbb::blocked_range<int>& rows) {
    // The band's window: `window` wide, its middle row's height (GroundWindowRows) tall; the
    // texture gate scales with the window's area (the same mean squared slope).
    const int r = window_rows ? (*window_rows)[(rows.begin() + rows.end()) / 2] / 2 : rh;
    const float band_min_weight = min_weight * static_cast<float>(2 * r + 1) / static_cast<float>(2 * rh + 1);
    const int y0 = std::max(0, rows.begin() - r), y1 = std::min(H, rows.end() + r);
    // The fit's squared residuals are summed about an offset near the band's disparities (the
    // rounded mean of its middle row): about 0, float sums of k^2-sized terms would cancel.
    int c = 0;
    if (fit) {
      const int vm = (rows.begin() + rows.end()) / 2;
      const float* d = sgm.ptr<float>(vm);
      const uint8_t* m = valid.ptr<uint8_t>(vm);
      double sum = 0;
      int n = 0;
      for (int u = 0; u < W; ++u)
        if (m[u]) sum += d[u], ++n;
      c = n ? static_cast<int>(std::lround(sum / n)) : 0;
    }
    std::vector<float> num(static_cast<size_t>(y1 - y0) * W), den(num.size()), fit_terms(fit ? num.size() : 0);
    std::vector<int> k_row(W);
    for (int y = y0; y < y1; ++y) {
      const size_t at = static_cast<size_t>(y - y0) * W;
      RefineTermsRow(ref_hp.ptr<int16_t>(y), target_hp.ptr<int16_t>(y), terms.ptr<uint8_t>(y), sgm.ptr<float>(y), W,
                     k_row.data(), num.data() + at, den.data() + at, c, fit ? fit_terms.data() + at : nullptr);
    }
    std::vector<float> col_n(W + 2 * rh, 0.0f), col_d(W + 2 * rh, 0.0f), sum_n(W), sum_d(W);
    std::vector<float> col_f(fit ? W + 2 * rh : 0, 0.0f), sum_f(fit ? W : 0);
    float *cn = col_n.data() + rh, *cd = col_d.data() + rh, *cf = fit ? col_f.data() + rh : nullptr;
    auto add_row = [&](int y, float sign) {
      if (y < y0 || y >= y1) return;
      AddRow(num.data() + static_cast<size_t>(y - y0) * W, W, sign, cn);
      AddRow(den.data() + static_cast<size_t>(y - y0) * W, W, sign, cd);
      if (fit) AddRow(fit_terms.data() + static_cast<size_t>(y - y0) * W, W, sign, cf);
    };
    for (int y = rows.begin() - r; y <= rows.begin() + r; ++y) add_row(y, 1.0f);
    for (int v = rows.begin(); v < rows.end(); ++v) {
      if (v > rows.begin()) add_row(v + r, 1.0f), add_row(v - r - 1, -1.0f);
      BoxRow(cn, W, rh, sum_n.data());
      BoxRow(cd, W, rh, sum_d.data());
      RefineApplyRow(sum_n.data(), sum_d.data(), valid.ptr<uint8_t>(v), W, band_min_weight, sgm.ptr<float>(v),
                     out->ptr<float>(v));
      if (agree) AgreeRow(sum_d.data(), W, agree_px, agree->ptr<uint16_t>(v));
      if (fit) {
        BoxRow(cf, W, rh, sum_f.data());
        FitRow(sum_n.data(), sum_d.data(), sum_f.data(), W, c, band_min_weight, fit->value.ptr<float>(v),
               fit->spread.ptr<float>(v));
      }
    }
  });
}

// Shiftable windows (edge-preserving): at a valid pixel whose centred window straddles a change of
// disparity (a pothole's wall, a kerb) the window's fit spreads the far side's disparity onto the
// pixel. Of the 8 windows of the same size that still contain the pixel at an edge or corner
// (centres r px away along the rows, columns and diagonals), the one with the smallest spread
// (RefineFit) lies on the pixel's own side; its value replaces `out` where the centred window's
// spread exceeds `ratio` times that smallest spread (so on uniform road, where all spreads are
// noise of the same size, the centred value stays). Candidates more than 1 px from the pixel's
// SGM value `sgm` are not taken (the same gate as the centred window's), nor ones farther from
// `local` (an estimate of the pixel's own that no wider window blurred) than the centred value: on a
// sloping wall every window fits a ramp equally badly and the flat road beside it fits best, and
// without this test the wall's pixels would take the road's value.
void ShiftWindows(const cv::Mat& sgm, const cv::Mat& valid, const RefineFit& fit, const cv::Mat& local, int r,
                  float ratio, cv::Mat* out) {
  const int W = sgm.cols, H = sgm.rows;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 32), [&](const tbb::blocked_range<int>& rows) {
    std::vector<float> best_s(W), best_l(W);
    for (int v = rows.begin(); v < rows.end(); ++v) {
      const float* __restrict d = sgm.ptr<float>(v);
      const float* __restrict lc = fit.value.ptr<float>(v);
      const float* __restrict ll = local.ptr<float>(v);
      std::fill(best_s.begin(), best_s.end(), kInf);
      float* __restrict bs = best_s.data(), * __restrict bl = best_l.data();
      for (int dv = -r; dv <= r; dv += r) {
        if (v + dv < 0 || v + dv >= H) continue;
        const float* __restrict cs = fit.spread.ptr<float>(v + dv), * __restrict cl = fit.value.ptr<float>(v + dv);
        for (int du = -r; du <= r; du += r) {
          if (du == 0 && dv == 0) continue;
          const int lo = std::max(0, -du), hi = std::min(W, W - du);
          for (int u = lo; u < hi; ++u) {  // branch-free: vectorises
            const float s = cs[u + du], l = cl[u + du];
            const bool better =
                (s < bs[u]) & (std::abs(l - d[u]) <= 1.0f) & (std::abs(l - ll[u]) <= std::abs(lc[u] - ll[u]));
            bs[u] = better ? s : bs[u];
            bl[u] = better ? l : bl[u];
          }
        }
      }
      const float* __restrict s0 = fit.spread.ptr<float>(v);
      const uint8_t* __restrict m = valid.ptr<uint8_t>(v);
      float* __restrict o = out->ptr<float>(v);
      for (int u = 0; u < W; ++u) {
        const bool take = (m[u] != 0) & (s0[u] < kInf) & (s0[u] > ratio * bs[u]);
        o[u] = take ? bl[u] : o[u];
      }
    }
  });
}

// Where one straight, mostly vertical edge dominates the window x window window of `img` (CV_8U,
// 255): structure-tensor coherence (l1 - l2) / (l1 + l2) above max_coherence (~0.3 on random
// texture, -> 1 for a single edge) with sum gx^2 >= 2 sum gy^2 (horizontal edges, and texture
// foreshortened along the rows, give the row-wise matching little and are left alone).
void EdgeDominated(const cv::Mat& img, int window, float max_coherence, cv::Mat* out) {
  thread_local cv::Mat tls[5];  // reused (page faults); named by reference: other threads have their own
  cv::Mat &gx = tls[0], &gy = tls[1], &xx = tls[2], &yy = tls[3], &xy = tls[4];
  cv::spatialGradient(img, gx, gy, 3, cv::BORDER_REPLICATE);  // Sobel 3x3, CV_16S
  xx.create(img.size(), CV_32F), yy.create(img.size(), CV_32F), xy.create(img.size(), CV_32F);
  tbb::parallel_for(tbb::blocked_range<int>(0, img.rows, 32), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      const int16_t *x = gx.ptr<int16_t>(v), *y = gy.ptr<int16_t>(v);
      float *a = xx.ptr<float>(v), *b = yy.ptr<float>(v), *c = xy.ptr<float>(v);
      for (int u = 0; u < img.cols; ++u) {
        const float fx = x[u], fy = y[u];
        a[u] = fx * fx, b[u] = fy * fy, c[u] = fx * fy;
      }
    }
  });
  const cv::Size box(window, window);
  tbb::parallel_invoke([&] { cv::boxFilter(xx, xx, -1, box, cv::Point(-1, -1), true, cv::BORDER_REPLICATE); },
                       [&] { cv::boxFilter(yy, yy, -1, box, cv::Point(-1, -1), true, cv::BORDER_REPLICATE); },
                       [&] { cv::boxFilter(xy, xy, -1, box, cv::Point(-1, -1), true, cv::BORDER_REPLICATE); });
  out->create(img.size(), CV_8U);
  // (l1 - l2)^2 > c^2 (l1 + l2)^2, without the square root.
  const float c2 = max_coherence * max_coherence;
  tbb::parallel_for(tbb::blocked_range<int>(0, img.rows, 32), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      const float *a = xx.ptr<float>(v), *b = yy.ptr<float>(v), *c = xy.ptr<float>(v);
      uint8_t* o = out->ptr<uint8_t>(v);
      for (int u = 0; u < img.cols; ++u) {
        const float d = a[u] - b[u], t = a[u] + b[u];
        const bool edge = (d * d + 4 * c[u] * c[u] > c2 * t * t) & (a[u] >= 2 * b[u]) & (t > 0);
        o[u] = static_cast<uint8_t>(0 - static_cast<int>(edge));
      }
    }
  });
}

}  // namespace

void RefineSubpixel(const cv::Mat& ref, const cv::Mat& target, cv::Mat* disparity, const cv::Mat& valid, int window) {
  SubpixelRefineOptions o;
  o.window = window;
  RefineSubpixel(ref, target, disparity, valid, o);
}

void RefineSubpixel(const cv::Mat& ref, const cv::Mat& target, cv::Mat* disparity, const cv::Mat& valid,
                    const SubpixelRefineOptions& o, cv::Mat* window_value) {
  if (o.window <= 0) {
    if (window_value) disparity->copyTo(*window_value);
    return;
  }
  // Texture the small window needs: a mean squared slope of 4 (2 grey levels per px; G = 24 x
  // slope). Below it (inside a painted line, a shadow's flat core) the intensities say little at
  // this size and SGM's value stays.
  constexpr float kMinMeanWeight = 4.0f * 24.0f * 24.0f;
  // The smooth window is gated on its own precision instead: its least-squares shift has a
  // standard deviation of 24 sigma_e / sqrt(sum G^2) (sigma_e: the residual's noise, ~0.5 grey
  // levels after the pre-smoothing), so sum G^2 >= 20000 keeps it below ~0.1 px; a mean-slope gate
  // would leave weakly textured far road to SGM's values and their aggregation streaks.
  constexpr float kSmoothMinWeight = 20000.0f;
  // Agreement the smooth value needs with the small window's (AgreeRow): smooth_agree_px, or where
  // larger ~5 standard deviations of the small window's own estimate (24 x 0.5 x 5 / sqrt(sum G^2)
  // = kAgreeScale / sqrt(sum G^2)): on weak texture the small window's value is noise, and a fixed
  // tolerance would reject the smooth value over most of the far road.
  auto min_weight = [](int w) { return kMinMeanWeight * static_cast<float>(w * w); };
  const bool smooth = o.smooth_window > o.window, edges = smooth && o.max_edge_coherence < 1;
  // High-pass both images (minus a local mean): the cameras' gain and vignetting differ, and an
  // intensity offset between the views biases an intensity residual (the census SGM ran on is
  // immune to it, this least-squares step is not).
  thread_local cv::Mat tls_ref_hp, tls_target_hp;  // reused across frames (page faults)
  cv::Mat &ref_hp = tls_ref_hp, &target_hp = tls_target_hp;
  thread_local cv::Mat tls_edge;
  cv::Mat& edge = tls_edge;
  tbb::parallel_invoke([&] { HighPass(ref, o.highpass, &ref_hp); }, [&] { HighPass(target, o.highpass, &target_hp); },
                       [&] {
                         if (edges) EdgeDominated(ref, o.window, static_cast<float>(o.max_edge_coherence), &edge);
                       });
  thread_local cv::Mat tls_sgm_in, tls_smooth, tls_terms, tls_agree;
  cv::Mat &sgm_in = tls_sgm_in, &smoothed = tls_smooth, &terms = tls_terms, &agree_map = tls_agree;
  disparity->copyTo(sgm_in);  // SGM's values: both passes read their integer winners there
  RefinePass(ref_hp, target_hp, sgm_in, disparity, valid, valid, o.window, min_weight(o.window),
             smooth ? &agree_map : nullptr, static_cast<float>(o.smooth_agree_px), nullptr,
             o.window_rows.empty() ? nullptr : &o.window_rows);
  if (!smooth) {
    if (window_value) disparity->copyTo(*window_value);
    return;
  }
  // One straight, mostly vertical edge dominating the small window (a hard shadow, a paint edge):
  // the match rests on where each camera's pixel grid cut that edge, an error that varies slowly
  // along it instead of averaging out over texture. Such pixels give no terms to the smooth window, and
  // take its value: the texture around them.
  if (edges) cv::bitwise_and(valid, ~edge, terms);
  // Shiftable smooth windows: where the centred 21x21 window straddles a pothole's wall (within
  // 10 px of it) a window beside the pixel replaces it, its value checked against the small
  // window's. The small window stays centred (docs/stages/disparity.md, "Pothole walls: shiftable
  // refinement windows").
  thread_local RefineFit tls_fit;
  const bool shift = o.shift_ratio > 0;
  RefinePass(ref_hp, target_hp, sgm_in, &smoothed, valid, edges ? terms : valid, o.smooth_window, kSmoothMinWeight,
             nullptr, 0, shift ? &tls_fit : nullptr);
  if (shift)
    ShiftWindows(sgm_in, valid, tls_fit, *disparity, o.smooth_window / 2, static_cast<float>(o.shift_ratio), &smoothed);
  // Elsewhere the smooth window's value is taken where it agrees with the small window's within
  // smooth_agree_px (no structure the small window resolves and the large one would blur, e.g. a
  // pothole's wall), the value is at most smooth_max_px (the road and below it, not obstacles) and
  // no edge dominates the small one.
  const float max_value = static_cast<float>(o.smooth_max_px);
  if (window_value) window_value->create(valid.size(), CV_32F);
  tbb::parallel_for(tbb::blocked_range<int>(0, valid.rows, 32), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      const float* __restrict b = smoothed.ptr<float>(v), * __restrict s0 = sgm_in.ptr<float>(v);
      const uint16_t* __restrict agree2 = agree_map.ptr<uint16_t>(v);  // squared, 1/10000 px^2
      const uint8_t* __restrict e = edges ? edge.ptr<uint8_t>(v) : valid.ptr<uint8_t>(v);
      const uint8_t* __restrict m = valid.ptr<uint8_t>(v);
      float* __restrict d = disparity->ptr<float>(v);
      if (window_value) std::memcpy(window_value->ptr<float>(v), d, sizeof(float) * valid.cols);
      const int edge_bit = edges ? 1 : 0;
      for (int u = 0; u < valid.cols; ++u) {  // branch-free: vectorises
        const int ok = static_cast<int>(m[u] != 0) & static_cast<int>(d[u] <= max_value);
        const int on_edge = static_cast<int>(e[u] != 0) & edge_bit;
        // On an edge: the smooth window's value where it refined the pixel (else the small
        // window's stays); elsewhere where both agree.
        const float diff = b[u] - d[u];
        const int agrees = static_cast<int>(diff * diff * 10000.0f <= static_cast<float>(agree2[u]));
        const int take = ok & ((on_edge & static_cast<int>(b[u] != s0[u])) | ((on_edge ^ 1) & agrees));
        d[u] = take ? b[u] : d[u];
      }
    }
  });
}

// Fewer rows leave the least-squares step too noisy at the far end of an oblique view's analysed
// range (fragments of far potholes turn into false detections).
constexpr int kMinGroundWindowRows = 5;

std::vector<int> GroundWindowRows(const RoadModel& road, int width, int height, double focal_px, int window) {
  std::vector<int> rows(static_cast<size_t>(std::max(0, height)), window);
  if (!(focal_px > 0) || window < 3) return rows;
  const double uc = 0.5 * (width - 1), vc = 0.5 * (height - 1);
  const double d0 = road.At(uc, vc);
  const double gu = road.At(uc + 0.5, vc) - road.At(uc - 0.5, vc), gv = road.At(uc, vc + 0.5) - road.At(uc, vc - 0.5);
  const double fb_over_h = std::sqrt(d0 * d0 + focal_px * focal_px * (gu * gu + gv * gv));
  if (!(fb_over_h > 0)) return rows;
  for (int v = 0; v < height; ++v) {
    const double aspect = road.At(uc, v) / fb_over_h;  // sin of the depression angle
    if (!(aspect > 0) || aspect >= 1) continue;
    const int h = 2 * static_cast<int>(std::lround(0.5 * (window * aspect - 1))) + 1;  // nearest odd
    rows[static_cast<size_t>(v)] = std::clamp(h, std::min(kMinGroundWindowRows, window), window);
  }
  return rows;
}

int64_t FillSmallHoles(cv::Mat* disparity, cv::Mat* valid, int min_neighbours, double max_spread_px) {
  if (min_neighbours <= 0 || min_neighbours > 8) return 0;
  const int W = disparity->cols, H = disparity->rows;
  std::vector<std::vector<std::pair<int, float>>> fills(static_cast<size_t>(std::max(0, H)));
  tbb::parallel_for(tbb::blocked_range<int>(1, std::max(1, H - 1), 32), [&](const tbb::blocked_range<int>& r) {
    float vals[8];
    for (int v = r.begin(); v < r.end(); ++v) {
      const uint8_t* m[3] = {valid->ptr<uint8_t>(v - 1), valid->ptr<uint8_t>(v), valid->ptr<uint8_t>(v + 1)};
      const float* d[3] = {disparity->ptr<float>(v - 1), disparity->ptr<float>(v), disparity->ptr<float>(v + 1)};
      // memchr jumps to the next invalid pixel (a dense map has few).
      for (int u = 1; u + 1 < W; ++u) {
        const void* hole = std::memchr(m[1] + u, 0, static_cast<size_t>(W - 1 - u));
        if (!hole) break;
        u = static_cast<int>(static_cast<const uint8_t*>(hole) - m[1]);
        int n = 0;
        for (int y = 0; y < 3; ++y)
          for (int x = u - 1; x <= u + 1; ++x)
            if (m[y][x]) vals[n++] = d[y][x];
        if (n < min_neighbours) continue;
        std::sort(vals, vals + n);
        if (vals[n - 1] - vals[0] > max_spread_px) continue;
        fills[v].emplace_back(u, vals[(n - 1) / 2]);
      }
    }
  });
  int64_t count = 0;
  for (int v = 0; v < H; ++v)
    for (const auto& [u, value] : fills[v]) disparity->at<float>(v, u) = value, valid->at<uint8_t>(v, u) = 255, ++count;
  return count;
}

namespace {

// SGM's result and what the steps after it read.
struct SgmRun {
  SgmOutput sgm;
  std::vector<double> kappa;  // GPT-SGM: each row's road shift (ComputeGptShift)
  cv::Mat ref_s, target_s;    // the images SGM compared (the sub-pixel refinement reads them)
  // Largest SGM value that may take the smooth refinement window: 1 px above the road's residual
  // (after the per-pixel warp the road is at delta, else within [delta, delta + span]).
  double smooth_max_px = 0;
};

// GPT-SGM's road model from sparse matches over the whole common field of view; false (and
// fell_back) when it is unreliable or tilted beyond max_road_tilt_deg. `fallback` receives the
// plain-SGM range for a fall-back: sized from the matches where there are enough of them.
bool FitGptRoad(const cv::Mat& left, const cv::Mat& right, const DisparityParams& P, const RoadModel* prior,
                DisparityResult* out, DisparityRange* fallback) {
  DisparityResult& res = *out;
  const int W = left.cols, H = left.rows;
  const auto t0 = std::chrono::steady_clock::now();
  const auto samples = MatchSparseDisparities(left, right, P.road);
  res.road = FitRoadModel(samples, W, H, P.road, prior);
  *fallback = {P.min_disparity, P.num_disparities};
  if (P.fallback_range_from_matches) {
    const DisparityRange r = DisparityRangeOfMatches(samples, W, P.gpt_headroom_px, P.road.min_inliers);
    if (r.num > 0) *fallback = r;
  }
  res.road_tilt_rad = std::numeric_limits<double>::quiet_NaN();
  if (P.camera_focal_px > 0 && res.road.num_inliers >= 3) {
    // The principal point is not among the parameters: the image centre (a shift of c_x by a few
    // per cent of the width moves the tilt by well under a degree).
    res.road_tilt_rad = RoadLateralTiltRad(res.road, P.camera_focal_px, 0.5 * (W - 1), 0.5 * (H - 1));
    if (P.max_road_tilt_deg > 0 && std::abs(res.road_tilt_rad) > P.max_road_tilt_deg * M_PI / 180 &&
        res.road.reliable)
      res.road.reliable = false, res.road_tilt_rejected = true;
  }
  res.timings.road_model_ms = MsSince(t0);
  if (!res.road.reliable) {
    res.fell_back = true;
    return false;
  }
  return true;
}

// GPT-SGM: the target warped by the road model (or its rows shifted inside SGM), then SGM over
// the residual range, widened where the road's span along a row needs it.
SgmRun RunGptSgm(const cv::Mat& left, const cv::Mat& right, const DisparityParams& P, DisparityResult* out) {
  DisparityResult& res = *out;
  const int W = left.cols, H = left.rows;
  SgmRun run;
  const auto t0 = std::chrono::steady_clock::now();
  run.kappa = ComputeGptShift(res.road, W, H, P.gpt_delta_px);
  const std::vector<double>& kappa = run.kappa;
  double span = 0;  // largest road residual above the row minimum
  for (int v = 0; v < H; ++v)
    span = std::max(span, std::max(res.road.At(0, v), res.road.At(W - 1, v)) - res.road.RowMin(v, W));
  int num_d = P.gpt_num_disparities;
  if (P.gpt_expand_range)
    num_d = std::max(num_d, static_cast<int>(std::ceil(P.gpt_delta_px + span + P.gpt_headroom_px)));
  num_d = std::min(num_d, 1024);
  res.num_disparities = num_d;
  SgmParams sp = P.ToSgm(0, num_d);
  cv::Mat target = right;
  run.smooth_max_px = P.gpt_delta_px + (P.gpt_subpixel_warp && P.gpt_pixel_warp ? 0.0 : span) + 1.0;
  if (P.gpt_subpixel_warp && P.gpt_pixel_warp) {
    target = WarpTargetPerPixel(right, res.road, P.gpt_delta_px);
  } else if (P.gpt_subpixel_warp) {
    target = WarpTarget(right, kappa);
  } else {
    sp.row_offset.resize(H);
    for (int v = 0; v < H; ++v) sp.row_offset[v] = static_cast<int>(std::floor(kappa[v]));
  }
  run.ref_s = Presmooth(left, P.presmooth_sigma_px), run.target_s = Presmooth(target, P.presmooth_sigma_px);
  res.timings.warp_ms = MsSince(t0);
  run.sgm = ComputeSgm(run.ref_s, run.target_s, sp);
  res.method_used = DisparityMethod::kGptSgm;
  return run;
}

// Plain SGM over [min_disparity, min_disparity + num_disparities).
SgmRun RunPlainSgm(const cv::Mat& left, const cv::Mat& right, const DisparityParams& P, DisparityResult* out) {
  DisparityResult& res = *out;
  SgmRun run;
  res.min_disparity = P.min_disparity;
  res.num_disparities = P.num_disparities;
  const auto t0 = std::chrono::steady_clock::now();
  run.ref_s = Presmooth(left, P.presmooth_sigma_px), run.target_s = Presmooth(right, P.presmooth_sigma_px);
  res.timings.warp_ms = MsSince(t0);
  run.sgm = ComputeSgm(run.ref_s, run.target_s, P.ToSgm(P.min_disparity, P.num_disparities));
  res.method_used = DisparityMethod::kSgm;
  return run;
}

// Sub-pixel refinement, speckle filter, median and small-hole filling of SGM's result, in place.
// With GPT-SGM's smooth window, `sharp_l` receives the small window's value alone
// (DisparityResult::disparity_sharp); returns whether it did.
bool RefineAndClean(const DisparityParams& P, bool gpt, const RoadModel& road, SgmRun* run, cv::Mat* sharp_l) {
  SgmOutput& sgm = run->sgm;
  const int W = sgm.disparity.cols, H = sgm.disparity.rows;
  SubpixelRefineOptions refine;
  refine.window = P.refine_window;
  refine.max_edge_coherence = P.refine_max_coherence;
  refine.highpass = P.refine_highpass_px;
  refine.shift_ratio = P.refine_shift_ratio;
  if (gpt && P.refine_ground_window)
    refine.window_rows = GroundWindowRows(road, W, H, P.camera_focal_px, P.refine_window);
  if (gpt)
    refine.smooth_window = P.refine_smooth_window, refine.smooth_agree_px = P.refine_smooth_agree_px,
    refine.smooth_max_px = run->smooth_max_px;
  const bool sharp = gpt && refine.window > 0 && refine.smooth_window > refine.window;
  RefineSubpixel(run->ref_s, run->target_s, &sgm.disparity, sgm.valid, refine, sharp ? sharp_l : nullptr);
  FilterSpeckles(&sgm.disparity, &sgm.valid, P.speckle_window_size, P.speckle_max_diff_px);
  // The sharp image takes the post-processing's validity: NaN where a speckle went (the median
  // reads valid neighbours only), the smooth image's value where a small hole is filled.
  if (sharp) sharp_l->setTo(std::numeric_limits<float>::quiet_NaN(), sgm.valid == 0);
  if (P.median) {
    if (sharp) MedianValid3x3(sharp_l, sgm.valid);
    MedianValid3x3(&sgm.disparity, sgm.valid);
  }
  FillSmallHoles(&sgm.disparity, &sgm.valid, P.fill_min_neighbours, P.speckle_max_diff_px);
  return sharp;
}

// Per-row counts of the final pass: textured pixels whose road point is visible in the right
// view (and how many of them are valid) for the fall-back rule, valid pixels for the density.
struct RowCounts {
  std::vector<int64_t> visible, visible_valid, valid;
};

// Textured pixels of row v (1 <= v < H - 1) whose road point is visible: the road point
// u - road(u, v) lies inside the right image, the road is in front of the camera there
// (road(u, v) >= 1 px: rows above a forward view's horizon do not count), and the left image has
// texture to match (central-difference gradient |dI/du| + |dI/dv| >= kTexture: the untextured
// side of a parked car or the sky would otherwise count against a correct road model).
void CountVisibleRow(const cv::Mat& left, const RoadModel& road, const uint8_t* m, int W, int v, int64_t* visible,
                     int64_t* visible_valid) {
  constexpr int kTexture = 8;
  const uint8_t *lm = left.ptr<uint8_t>(v), *lu = left.ptr<uint8_t>(v - 1), *ld = left.ptr<uint8_t>(v + 1);
  const double x_min = road.At(0, v), slope = road.At(1, v) - x_min;
  int64_t vis = 0, vis_valid = 0;
  for (int u = 1; u + 1 < W; ++u) {
    const double road_d = road.quadratic ? road.At(u, v) : x_min + slope * u;
    if (!(road_d >= 1.0 && u - road_d >= 0)) continue;
    if (std::abs(lm[u + 1] - lm[u - 1]) + std::abs(ld[u] - lu[u]) < kTexture) continue;
    ++vis, vis_valid += m[u] != 0;
  }
  *visible = vis, *visible_valid = vis_valid;
}

// One parallel pass over res.disparity / res.valid (SGM's, post-processed): true disparity
// (d = l + kappa after a sub-pixel warp), a match outside the target image dropped (after a warp
// the replicated border can still "match"; plain SGM already rejects them), the transformed
// disparity (GPT-SGM) and the per-row counts. `sharp_l` (optional) follows the same steps.
RowCounts TrueDisparityRows(const cv::Mat& left, const DisparityParams& P, bool gpt, const std::vector<double>& kappa,
                            cv::Mat* sharp_l, DisparityResult* out) {
  DisparityResult& res = *out;
  const int W = left.cols, H = left.rows;
  const bool sharp = sharp_l != nullptr;
  const bool warped = gpt && P.gpt_subpixel_warp;
  std::vector<int64_t> row_visible(H, 0), row_visible_valid(H, 0), row_valid(H, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      float* d = res.disparity.ptr<float>(v);
      uint8_t* m = res.valid.ptr<uint8_t>(v);
      float* ds = sharp ? sharp_l->ptr<float>(v) : nullptr;
      if (ds)  // filled holes: the smooth image's value
        for (int u = 0; u < W; ++u) ds[u] = m[u] && std::isnan(ds[u]) ? d[u] : ds[u];
      if (warped && P.gpt_pixel_warp) {
        // d = l + s(u - l, v), s = road - delta (the warp's own shift at the matched column).
        const double a = res.road.c[0] + res.road.c[2] * v + res.road.c[5] * v * v - P.gpt_delta_px,
                     b = res.road.c[1] + res.road.c[4] * v, c = res.road.c[3];
        PixelWarpToTrueRow(d, m, W, a, b, c);
        if (ds) PixelWarpToTrueRow(ds, m, W, a, b, c);
      } else if (warped) {
        RowWarpToTrueRow(d, m, W, kappa[v]);
        if (ds) RowWarpToTrueRow(ds, m, W, kappa[v]);
      }
      const int n_valid = DropOutsideRow(d, m, W);
      if (ds)  // the same validity (a match outside the target image went)
        for (int u = 0; u < W; ++u) ds[u] = KeepOrZero(ds[u], m[u] != 0);
      row_valid[v] = n_valid;
      if (!gpt) continue;
      TransformedDisparityRow(d, m, W, v, res.road, P.gpt_delta_px, res.transformed.ptr<float>(v));
      if (P.gpt_min_valid_fraction <= 0) continue;
      // Every 4th row is enough for a share (and keeps this pass cheap).
      if (v == 0 || v == H - 1 || v % 4 != 0) continue;
      CountVisibleRow(left, res.road, m, W, v, &row_visible[v], &row_visible_valid[v]);
    }
  });
  return {std::move(row_visible), std::move(row_visible_valid), std::move(row_valid)};
}

}  // namespace

DisparityResult ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const DisparityParams& P,
                                 const RoadModel* prior) {
  const auto t_start = std::chrono::steady_clock::now();
  P.Check();
  if (left.empty() || left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size())
    throw std::invalid_argument("disparity: inputs must be non-empty CV_8UC1 images of equal size");
  const int W = left.cols, H = left.rows;
  DisparityResult res;

  DisparityRange fallback{P.min_disparity, P.num_disparities};
  const bool gpt = P.method == DisparityMethod::kGptSgm && FitGptRoad(left, right, P, prior, &res, &fallback);
  DisparityParams plain = P;  // plain SGM: requested, or GPT-SGM's fall-back over its range
  plain.method = DisparityMethod::kSgm;
  plain.min_disparity = fallback.min, plain.num_disparities = fallback.num;
  SgmRun run = gpt ? RunGptSgm(left, right, P, &res) : RunPlainSgm(left, right, plain, &res);
  res.timings.census_ms = run.sgm.census_ms;
  res.timings.aggregation_ms = run.sgm.aggregation_ms;
  res.timings.wta_ms = run.sgm.wta_ms;

  auto t0 = std::chrono::steady_clock::now();
  cv::Mat sharp_l;
  const bool sharp = RefineAndClean(P, gpt, res.road, &run, &sharp_l);
  res.timings.postprocess_ms = MsSince(t0);

  t0 = std::chrono::steady_clock::now();
  res.valid = run.sgm.valid;
  res.disparity = run.sgm.disparity;              // after a warp, converted in place below (no fresh 4 MB per frame)
  if (gpt) res.transformed.create(H, W, CV_32F);  // the road model is known (reliable): fused below
  const RowCounts rows = TrueDisparityRows(left, P, gpt, run.kappa, sharp ? &sharp_l : nullptr, &res);
  int64_t visible = 0, visible_valid = 0, num_valid = 0;
  for (int v = 0; v < H; ++v)
    visible += rows.visible[v], visible_valid += rows.visible_valid[v], num_valid += rows.valid[v];
  if (gpt && P.gpt_min_valid_fraction > 0) {
    if (visible == 0 || visible_valid < P.gpt_min_valid_fraction * visible) {
      DisparityResult r = ComputeDisparity(left, right, plain, prior);
      r.fell_back = true;
      r.road_tilt_rad = res.road_tilt_rad;
      r.timings.total_ms = MsSince(t_start);
      return r;
    }
  }
  if (!gpt) {
    const auto tr = std::chrono::steady_clock::now();
    res.road = FitFromDense(res.disparity, res.valid, P.road, prior);
    res.timings.road_model_ms += MsSince(tr);
  }
  if (gpt) {
    // transformed: filled in the pass above
  } else if (res.road.reliable) {
    res.transformed = TransformedDisparity(res.disparity, res.valid, res.road, P.gpt_delta_px);
  } else {
    res.transformed = cv::Mat::zeros(H, W, CV_32F);
  }
  res.valid_fraction = static_cast<double>(num_valid) / static_cast<double>(res.valid.total());
  if (sharp) res.disparity_sharp = sharp_l;
  res.timings.transform_ms = MsSince(t0);
  res.timings.total_ms = MsSince(t_start);
  return res;
}

}  // namespace rs
