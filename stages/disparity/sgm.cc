// Optimised SGM. Layout: cost volume uint8 [v][u][Dp], aggregated sum uint16 [v][u][Dp],
// Dp = num_disparities rounded up to kLanes so one GCC vector (32 x uint16 = an AVX-512
// register where AVX512BW is enabled, else 16 x uint16 = AVX2; plain C++ lowers it elsewhere)
// covers kLanes disparities. Padded lanes carry a large bias so they never win a minimum; the
// bounds in SgmParams::Check keep every sum inside uint16.
//
// Passes: (1) per row, in parallel: cost + both horizontal paths (initialises S);
// (2) rows top-down, columns in parallel: vertical (+ two diagonals with 8 paths);
// (3) rows bottom-up, the opposite directions; (4) per row, in parallel: WTA, uniqueness,
// sub-pixel, left-right check. Integer sums make the result independent of order, hence
// bit-identical to the reference.
#include "stages/disparity/sgm.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace rs {
namespace {

#if defined(__AVX512BW__)
constexpr int kLanes = 32;
#else
constexpr int kLanes = 16;
#endif
using v16 = uint16_t __attribute__((vector_size(2 * kLanes)));
using vs16 = int16_t __attribute__((vector_size(2 * kLanes)));
using v16u8 = uint8_t __attribute__((vector_size(kLanes)));

constexpr uint16_t kBig = 0x1000;  // padded lanes / sentinels; > MaxCost + 2 * p2 by Check()

inline v16 Load(const uint16_t* p) {
  v16 r;
  std::memcpy(&r, p, sizeof(r));
  return r;
}
inline void Store(uint16_t* p, v16 v) { std::memcpy(p, &v, sizeof(v)); }
inline v16 LoadCost(const uint8_t* p) {
  v16u8 r;
  std::memcpy(&r, p, sizeof(r));
  return __builtin_convertvector(r, v16);
}
inline v16 VMin(v16 a, v16 b) { return a < b ? a : b; }
inline v16 Splat(uint16_t x) { return v16{} + x; }

inline uint16_t HMin(v16 v) {
#if defined(__AVX512BW__)
  __m256i lo, hi;  // halves by memcpy (GCC 12 warns spuriously inside _mm512_extracti64x4_epi64)
  std::memcpy(&lo, &v, sizeof(lo));
  std::memcpy(&hi, reinterpret_cast<const char*>(&v) + sizeof(lo), sizeof(hi));
  const __m256i x = _mm256_min_epu16(lo, hi);
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(x), _mm256_extracti128_si256(x, 1));
  return static_cast<uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)) & 0xFFFF);
#elif defined(__AVX2__)
  const __m256i x = reinterpret_cast<__m256i>(v);
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(x), _mm256_extracti128_si256(x, 1));
  return static_cast<uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)) & 0xFFFF);
#else
  uint16_t m = v[0];
  for (int i = 1; i < kLanes; ++i) m = std::min<uint16_t>(m, v[i]);
  return m;
#endif
}

// Index of the first lane equal to x, or -1.
inline int FirstEqual(v16 v, uint16_t x) {
#if defined(__AVX512BW__)
  const __mmask32 k = _mm512_cmpeq_epi16_mask(reinterpret_cast<__m512i>(v), _mm512_set1_epi16(static_cast<short>(x)));
  return k ? __builtin_ctz(k) : -1;
#elif defined(__AVX2__)
  const __m256i eq = _mm256_cmpeq_epi16(reinterpret_cast<__m256i>(v), _mm256_set1_epi16(static_cast<short>(x)));
  const unsigned mask = static_cast<unsigned>(_mm256_movemask_epi8(eq));
  return mask ? __builtin_ctz(mask) / 2 : -1;
#else
  for (int i = 0; i < kLanes; ++i)
    if (v[i] == x) return i;
  return -1;
#endif
}

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

struct Volume {
  int W = 0, H = 0, D = 0, Dp = 0;
  size_t capacity = 0;  // elements allocated
  std::unique_ptr<uint8_t[]> cost;  // uninitialised on purpose: every element is written
  std::unique_ptr<uint16_t[]> sum;
  const uint8_t* Cost(int v, int u) const { return cost.get() + (static_cast<size_t>(v) * W + u) * Dp; }
  uint16_t* Sum(int v, int u) const { return sum.get() + (static_cast<size_t>(v) * W + u) * Dp; }
};

// P2' = max(P1, P2 * g / (|dI| + g)) tabulated over |dI| in [0, 255].
struct Penalties {
  uint16_t p1;
  uint16_t table[256];
  Penalties(const SgmParams& P) : p1(static_cast<uint16_t>(P.p1)) {
    for (int grad = 0; grad < 256; ++grad)
      table[grad] = static_cast<uint16_t>(
          P.adaptive_p2 ? std::max(P.p1, P.p2 * P.p2_gradient_scale / (grad + P.p2_gradient_scale)) : P.p2);
  }
  uint16_t Eff(int a, int b) const { return table[a > b ? a - b : b - a]; }
};

// One path step: L(p,.) from L(p-r,.) (with kBig sentinels at index -1 and Dp).
// kInit: write S instead of accumulating. Returns min_k L(p,k).
template <bool kInit>
inline uint16_t Step(const uint8_t* C, const v16* bias, const uint16_t* Lprev, uint16_t min_prev, uint16_t p1,
                     uint16_t p2e, uint16_t* Lcur, uint16_t* S, int Dp) {
  const v16 vp1 = Splat(p1), vmp2 = Splat(static_cast<uint16_t>(min_prev + p2e)), vmp = Splat(min_prev);
  v16 mn = Splat(0xFFFF);
  for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
    const v16 cost = LoadCost(C + j) + bias[c];
    const v16 near = VMin(Load(Lprev + j - 1), Load(Lprev + j + 1)) + vp1;
    const v16 t = VMin(VMin(Load(Lprev + j), near), vmp2);
    const v16 l = cost + t - vmp;
    Store(Lcur + j, l);
    Store(S + j, kInit ? l : Load(S + j) + l);
    mn = VMin(mn, l);
  }
  return HMin(mn);
}

template <bool kInit>
inline uint16_t StepStart(const uint8_t* C, const v16* bias, uint16_t* Lcur, uint16_t* S, int Dp) {
  v16 mn = Splat(0xFFFF);
  for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
    const v16 l = LoadCost(C + j) + bias[c];
    Store(Lcur + j, l);
    Store(S + j, kInit ? l : Load(S + j) + l);
    mn = VMin(mn, l);
  }
  return HMin(mn);
}

// Buffer of n pixels' L vectors, each with sentinels: [kBig, L0..L(Dp-1), kBig].
struct LineBuffer {
  int Dp = 0, stride = 0;
  std::vector<uint16_t> data;
  std::vector<uint16_t> min;
  LineBuffer(int n, int dp) : Dp(dp), stride(dp + 2), data(static_cast<size_t>(n) * (dp + 2), kBig), min(n, 0) {}
  uint16_t* L(int i) { return data.data() + static_cast<size_t>(i) * stride + 1; }
};

// cr_rev / ir_rev: the target row reversed (index W - 1 - x), so the candidates of one
// reference pixel, x = base - k, are a forward run in k and the popcounts vectorise.
void ComputeCostRow(const SgmParams& P, const uint64_t* __restrict cl, const uint64_t* __restrict cr_rev,
                    const uint8_t* __restrict il, const uint8_t* __restrict ir_rev, int W, int D, int Dp, int offset,
                    uint8_t* __restrict out) {
  const uint8_t max_cost = static_cast<uint8_t>(P.MaxCost());
  const int adw = P.ad_weight, adt = P.ad_truncation;
  for (int u = 0; u < W; ++u) {
    uint8_t* __restrict c = out + static_cast<size_t>(u) * Dp;
    const int base = u - offset;  // target column x = base - k must lie in [0, W)
    const int klo = std::clamp(base - (W - 1), 0, D), khi = std::clamp(base + 1, klo, D);
    const uint64_t code = cl[u];
    const int iu = il[u];
    const int r0 = W - 1 - base;  // reversed index of x = base - k is r0 + k
    for (int k = 0; k < klo; ++k) c[k] = max_cost;
    if (adw > 0) {
      for (int k = klo; k < khi; ++k) {
        const int ad = std::min(std::abs(iu - int(ir_rev[r0 + k])), adt);
        c[k] = static_cast<uint8_t>(__builtin_popcountll(code ^ cr_rev[r0 + k]) + adw * ad);
      }
    } else {
      for (int k = klo; k < khi; ++k) c[k] = static_cast<uint8_t>(__builtin_popcountll(code ^ cr_rev[r0 + k]));
    }
    for (int k = khi; k < D; ++k) c[k] = max_cost;
    for (int k = D; k < Dp; ++k) c[k] = 0;
  }
}

}  // namespace

int SgmParams::MaxCost() const { return census_width * census_height - 1 + ad_weight * ad_truncation; }

void SgmParams::Check(int image_height) const {
  auto fail = [](const std::string& msg) { throw std::invalid_argument("sgm: " + msg); };
  const std::string cw = std::to_string(census_width), ch = std::to_string(census_height);
  if (census_width < 1 || census_width % 2 == 0)
    fail("census_width = " + cw + " violates census_width odd and >= 1");
  if (census_height < 1 || census_height % 2 == 0)
    fail("census_height = " + ch + " violates census_height odd and >= 1");
  if (census_width * census_height < 9 || census_width * census_height > 65)
    fail("census window " + cw + "x" + ch + " violates 9 <= width*height <= 65 (64-bit codes)");
  if (ad_weight < 0) fail("ad_weight = " + std::to_string(ad_weight) + " violates ad_weight >= 0");
  if (ad_truncation < 1) fail("ad_truncation = " + std::to_string(ad_truncation) + " violates ad_truncation >= 1");
  if (MaxCost() > 255)
    fail("max cost " + std::to_string(MaxCost()) + " violates census bits + ad_weight*ad_truncation <= 255");
  if (num_paths != 4 && num_paths != 8) fail("num_paths = " + std::to_string(num_paths) + " violates num_paths in {4, 8}");
  if (p1 < 1) fail("p1 = " + std::to_string(p1) + " violates p1 >= 1");
  if (p2 <= p1) fail("p2 = " + std::to_string(p2) + " violates p2 > p1 (p1 = " + std::to_string(p1) + ")");
  if (p2 > 1900) fail("p2 = " + std::to_string(p2) + " violates p2 <= 1900 (16-bit aggregation)");
  if (p2_gradient_scale < 1)
    fail("p2_gradient_scale = " + std::to_string(p2_gradient_scale) + " violates p2_gradient_scale >= 1");
  if (num_disparities < 1 || num_disparities > 1024)
    fail("num_disparities = " + std::to_string(num_disparities) + " violates 1 <= num_disparities <= 1024");
  if (!row_offset.empty() && static_cast<int>(row_offset.size()) != image_height)
    fail("row_offset has " + std::to_string(row_offset.size()) + " entries, violates size == image height (" +
         std::to_string(image_height) + ") or empty");
  if (uniqueness_ratio < 0 || uniqueness_ratio > 99)
    fail("uniqueness_ratio = " + std::to_string(uniqueness_ratio) + " violates 0 <= uniqueness_ratio <= 99");
}

namespace {

// Census codes into `codes` (W*H), tiled so a tile's codes stay in L1 across all window offsets.
void CensusInto(const cv::Mat& gray8, int window_width, int window_height, uint64_t* codes) {
  const int W = gray8.cols, H = gray8.rows, rw = window_width / 2, rh = window_height / 2;
  cv::Mat padded;
  cv::copyMakeBorder(gray8, padded, rh, rh, rw, rw, cv::BORDER_REPLICATE);
  constexpr int kTile = 256;
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 8), [&](const tbb::blocked_range<int>& r) {
    alignas(64) uint64_t tile[kTile];
    for (int v = r.begin(); v < r.end(); ++v) {
      for (int u0 = 0; u0 < W; u0 += kTile) {
        const int n = std::min(kTile, W - u0);
        std::fill(tile, tile + n, 0);
        const uint8_t* __restrict center = padded.ptr<uint8_t>(v + rh) + rw + u0;
        for (int dy = -rh; dy <= rh; ++dy) {
          const uint8_t* row = padded.ptr<uint8_t>(v + rh + dy) + rw + u0;
          for (int dx = -rw; dx <= rw; ++dx) {
            if (dy == 0 && dx == 0) continue;
            const uint8_t* __restrict nb = row + dx;
            for (int u = 0; u < n; ++u) tile[u] = (tile[u] << 1) | static_cast<uint64_t>(nb[u] < center[u]);
          }
        }
        std::copy(tile, tile + n, codes + static_cast<size_t>(v) * W + u0);
      }
    }
  });
}

}  // namespace

std::vector<uint64_t> CensusTransform(const cv::Mat& gray8, int window_width, int window_height) {
  std::vector<uint64_t> codes(gray8.total());
  CensusInto(gray8, window_width, window_height, codes.data());
  return codes;
}

SgmOutput ComputeSgm(const cv::Mat& left_gray8, const cv::Mat& right_gray8, const SgmParams& P) {
  if (left_gray8.type() != CV_8UC1 || right_gray8.type() != CV_8UC1 || left_gray8.size() != right_gray8.size() ||
      left_gray8.empty())
    throw std::invalid_argument("sgm: inputs must be non-empty CV_8UC1 images of equal size");
  P.Check(left_gray8.rows);
  const cv::Mat L = left_gray8.isContinuous() ? left_gray8 : left_gray8.clone();
  const cv::Mat R = right_gray8.isContinuous() ? right_gray8 : right_gray8.clone();
  const int W = L.cols, H = L.rows, D = P.num_disparities, Dp = (D + kLanes - 1) / kLanes * kLanes, nchunks = Dp / kLanes;
  auto offset = [&](int v) { return P.min_disparity + (P.row_offset.empty() ? 0 : P.row_offset[v]); };
  SgmOutput out;

  auto t0 = std::chrono::steady_clock::now();
  // Scratch kept per calling thread (named references so TBB workers see the caller's).
  thread_local std::vector<uint64_t> tls_cl, tls_cr;
  std::vector<uint64_t>& cl = tls_cl;
  std::vector<uint64_t>& cr = tls_cr;
  cl.resize(L.total()), cr.resize(R.total());
  CensusInto(L, P.census_width, P.census_height, cl.data());
  CensusInto(R, P.census_width, P.census_height, cr.data());
  out.census_ms = MsSince(t0);

  std::vector<v16> bias(nchunks, Splat(0));
  for (int k = D; k < Dp; ++k) bias[k / kLanes][k % kLanes] = kBig;
  const Penalties pen(P);

  // The volumes are kept per calling thread: re-faulting ~100 MB of fresh pages each frame costs
  // more than a frame's aggregation on small ranges.
  // (A named reference, so worker threads inside the lambdas see the caller's instance.)
  thread_local Volume tls_volume;
  Volume& vol = tls_volume;
  const size_t n = static_cast<size_t>(W) * H * Dp;
  if (n > vol.capacity) {
    vol.cost.reset();
    vol.sum.reset();
    vol.cost.reset(new uint8_t[n]);
    vol.sum.reset(new uint16_t[n]);
    vol.capacity = n;
  }
  vol.W = W, vol.H = H, vol.D = D, vol.Dp = Dp;
  const uint8_t* img = L.ptr<uint8_t>(0);
  auto I = [&](int v, int u) -> int { return img[static_cast<size_t>(v) * W + u]; };

  // Pass 1: cost and horizontal paths, independent per row.
  t0 = std::chrono::steady_clock::now();
  std::atomic<double> cost_ms_total{0};
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 4), [&](const tbb::blocked_range<int>& r) {
    LineBuffer buf(2, Dp);
    std::vector<uint64_t> cr_rev(W);
    std::vector<uint8_t> ir_rev(W);
    for (int v = r.begin(); v < r.end(); ++v) {
      const auto tc = std::chrono::steady_clock::now();
      const uint64_t* crow = cr.data() + static_cast<size_t>(v) * W;
      const uint8_t* irow = R.ptr<uint8_t>(v);
      std::reverse_copy(crow, crow + W, cr_rev.begin());
      std::reverse_copy(irow, irow + W, ir_rev.begin());
      ComputeCostRow(P, cl.data() + static_cast<size_t>(v) * W, cr_rev.data(), L.ptr<uint8_t>(v), ir_rev.data(), W, D,
                     Dp, offset(v), vol.cost.get() + static_cast<size_t>(v) * W * Dp);
      cost_ms_total.fetch_add(MsSince(tc));
      uint16_t *prev = buf.L(0), *cur = buf.L(1);
      uint16_t mp = StepStart<true>(vol.Cost(v, 0), bias.data(), prev, vol.Sum(v, 0), Dp);
      for (int u = 1; u < W; ++u) {
        mp = Step<true>(vol.Cost(v, u), bias.data(), prev, mp, pen.p1, pen.Eff(I(v, u), I(v, u - 1)), cur,
                        vol.Sum(v, u), Dp);
        std::swap(prev, cur);
      }
      mp = StepStart<false>(vol.Cost(v, W - 1), bias.data(), prev, vol.Sum(v, W - 1), Dp);
      for (int u = W - 2; u >= 0; --u) {
        mp = Step<false>(vol.Cost(v, u), bias.data(), prev, mp, pen.p1, pen.Eff(I(v, u), I(v, u + 1)), cur,
                         vol.Sum(v, u), Dp);
        std::swap(prev, cur);
      }
    }
  });

  // Passes 2 and 3: sweep rows; each row's columns are independent given the previous row.
  const int ndirs = P.num_paths == 8 ? 3 : 1;
  const int dus[3] = {0, 1, -1};  // previous pixel column = u - du
  if (ndirs == 1) {
    // Vertical paths only: columns are independent, so blocks of columns sweep the whole
    // image without a barrier per row.
    tbb::parallel_for(tbb::blocked_range<int>(0, W, 256), [&](const tbb::blocked_range<int>& r) {
      const int n = static_cast<int>(r.size());
      LineBuffer a(n, Dp), b(n, Dp);
      for (int sweep = 0; sweep < 2; ++sweep)
        for (int step = 0; step < H; ++step) {
          const int v = sweep == 0 ? step : H - 1 - step, vp = sweep == 0 ? v - 1 : v + 1;
          for (int i = 0; i < n; ++i) {
            const int u = r.begin() + i;
            b.min[i] = step == 0 ? StepStart<false>(vol.Cost(v, u), bias.data(), b.L(i), vol.Sum(v, u), Dp)
                                 : Step<false>(vol.Cost(v, u), bias.data(), a.L(i), a.min[i], pen.p1,
                                               pen.Eff(I(v, u), I(vp, u)), b.L(i), vol.Sum(v, u), Dp);
          }
          std::swap(a, b);
        }
    });
  }
  for (int sweep = 0; sweep < 2 && ndirs > 1; ++sweep) {
    std::vector<LineBuffer> prevb, curb;
    for (int d = 0; d < ndirs; ++d) prevb.emplace_back(W, Dp), curb.emplace_back(W, Dp);
    for (int step = 0; step < H; ++step) {
      const int v = sweep == 0 ? step : H - 1 - step;
      const int vp = sweep == 0 ? v - 1 : v + 1;
      tbb::parallel_for(tbb::blocked_range<int>(0, W, 64), [&](const tbb::blocked_range<int>& r) {
        for (int u = r.begin(); u < r.end(); ++u) {
          for (int d = 0; d < ndirs; ++d) {
            const int up = u - dus[d];
            if (step == 0 || up < 0 || up >= W) {
              curb[d].min[u] = StepStart<false>(vol.Cost(v, u), bias.data(), curb[d].L(u), vol.Sum(v, u), Dp);
            } else {
              curb[d].min[u] = Step<false>(vol.Cost(v, u), bias.data(), prevb[d].L(up), prevb[d].min[up], pen.p1,
                                           pen.Eff(I(v, u), I(vp, up)), curb[d].L(u), vol.Sum(v, u), Dp);
            }
          }
        }
      });
      std::swap(prevb, curb);
    }
  }
  out.aggregation_ms = MsSince(t0);
  out.cost_ms = cost_ms_total.load();

  // Pass 4: winner-takes-all, uniqueness, sub-pixel, left-right check.
  t0 = std::chrono::steady_clock::now();
  out.disparity = cv::Mat::zeros(H, W, CV_32F);
  out.valid = cv::Mat::zeros(H, W, CV_8U);
  vs16 iota;
  for (int i = 0; i < kLanes; ++i) iota[i] = static_cast<int16_t>(i);
  const bool lr = P.lr_max_diff >= 0;
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 4), [&](const tbb::blocked_range<int>& r) {
    std::vector<int> best(W);
    // Right-view winner per target column x, stored at y = W - 1 - x (+ Dp margin) so that one
    // left pixel's candidates form a forward contiguous run: y = W - 1 - u + off + k.
    std::vector<uint16_t> rcost(W + 2 * Dp), rk(W + 2 * Dp);
    for (int v = r.begin(); v < r.end(); ++v) {
      const int off = offset(v);
      float* disp = out.disparity.ptr<float>(v);
      uint8_t* valid = out.valid.ptr<uint8_t>(v);
      std::fill(rcost.begin(), rcost.end(), 0xFFFF);
      for (int u = 0; u < W; ++u) {
        const uint16_t* S = vol.Sum(v, u);
        v16 mn = Splat(0xFFFF);
        for (int j = 0; j < Dp; j += kLanes) mn = VMin(mn, Load(S + j));
        const uint16_t smin = HMin(mn);
        int b = 0;
        for (int j = 0; j < Dp; j += kLanes) {
          const int i = FirstEqual(Load(S + j), smin);
          if (i >= 0) {
            b = j + i;
            break;
          }
        }
        best[u] = b;
        const int y0 = W - 1 - u + off;
        if (lr && y0 + Dp > 0 && y0 < W) {
          uint16_t* rc = rcost.data() + Dp + y0;
          uint16_t* rki = rk.data() + Dp + y0;
          for (int j = 0; j < Dp; j += kLanes) {
            const v16 s = Load(S + j), c = Load(rc + j);
            const v16 better = s < c;  // strict: the smallest k wins ties (u ascending = k ascending)
            Store(rc + j, better ? s : c);
            Store(rki + j, better ? reinterpret_cast<v16>(iota) + static_cast<uint16_t>(j) : Load(rki + j));
          }
        }
        bool ok = true;
        if (P.uniqueness_ratio > 0) {
          const vs16 lo = vs16{} + static_cast<int16_t>(b - 1), hi = vs16{} + static_cast<int16_t>(b + 1);
          v16 m2 = Splat(0xFFFF);
          for (int j = 0; j < Dp; j += kLanes) {
            const vs16 idx = iota + static_cast<int16_t>(j);
            const vs16 excl = (idx >= lo) & (idx <= hi);
            m2 = VMin(m2, Load(S + j) | reinterpret_cast<v16>(excl));
          }
          const int s2 = HMin(m2);
          if (s2 * (100 - P.uniqueness_ratio) < static_cast<int>(smin) * 100) ok = false;
        }
        const int x = u - off - b;
        if (x < 0 || x >= W) ok = false;
        float sub = 0.0f;
        if (P.subpixel != SubpixelMode::kNone && b > 0 && b < D - 1) sub = SubpixelOffset(S[b - 1], S[b], S[b + 1], P.subpixel);
        valid[u] = ok ? 255 : 0;
        disp[u] = ok ? static_cast<float>(off + b) + sub : 0.0f;
      }
      if (!lr) continue;
      for (int u = 0; u < W; ++u) {
        if (!valid[u]) continue;
        const int y = W - 1 - (u - off - best[u]) + Dp;  // x checked in range above
        if (rcost[y] == 0xFFFF || std::abs(int(rk[y]) - best[u]) > P.lr_max_diff) valid[u] = 0, disp[u] = 0.0f;
      }
    }
  });
  out.wta_ms = MsSince(t0);
  return out;
}

}  // namespace rs
