// Optimised SGM. Layout: cost volume uint8 [v][u][Dp], aggregated sum uint16 [v][u][Dp],
// Dp = num_disparities rounded up to kLanes so one GCC vector (32 x uint16 = an AVX-512
// register where AVX512BW is enabled, else 16 x uint16 = AVX2; plain C++ lowers it elsewhere)
// covers kLanes disparities. Padded lanes carry a large bias so they never win a minimum; the
// bounds in SgmParams::Check keep every sum inside uint16.
//
// Passes (4 paths, the default): (1) a TBB pipeline over pairs of rows: cost + both horizontal
// paths in parallel (initialises S), then the downward path in row order while the rows are
// still in cache; (2) column blocks in parallel, rows bottom-up: the upward path, whose final
// sums go straight into winner-takes-all, uniqueness, sub-pixel and the right-view winners
// (never stored), two blocks per thread; (3) per row, in parallel: left-right check.
// With 8 paths: (1) without the downward path; row sweeps top-down and bottom-up with columns in
// parallel (vertical + diagonals) complete S; winner-takes-all per row; (3) as above.
// Integer sums and order-independent minima make the result independent of the schedule, hence
// bit-identical to the reference.
#include "stages/disparity/sgm.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include <opencv2/core.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

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
  // Upper half onto the lower by a lane shuffle (stays in registers; a memcpy split went
  // through the stack), then the AVX2/SSE4.1 reduction on the low 256 bits.
  using m16 = uint16_t __attribute__((vector_size(2 * kLanes)));
  constexpr m16 upper = {16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31,
                         16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31};
  const v16 folded = VMin(v, __builtin_shuffle(v, upper));
  __m256i x;  // low half; memcpy, as _mm512_castsi512_si256 trips a spurious GCC 12 warning
  std::memcpy(&x, &folded, sizeof(x));
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

// Bit i set where lane i <= t.
inline uint32_t LanesLe(v16 v, uint16_t t) {
#if defined(__AVX512BW__)
  return _mm512_cmple_epu16_mask(reinterpret_cast<__m512i>(v), _mm512_set1_epi16(static_cast<short>(t)));
#elif defined(__AVX2__) && defined(__BMI2__)
  const __m256i x = reinterpret_cast<__m256i>(v);
  const __m256i le = _mm256_cmpeq_epi16(_mm256_min_epu16(x, _mm256_set1_epi16(static_cast<short>(t))), x);
  return _pext_u32(static_cast<uint32_t>(_mm256_movemask_epi8(le)), 0x55555555u);
#else
  uint32_t m = 0;
  for (int i = 0; i < kLanes; ++i) m |= (v[i] <= t ? 1u : 0u) << i;
  return m;
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

// How a path step combines its L(p,.) with the sum volume.
enum class Acc {
  kInit,  // S = L
  kAdd,   // S += L
  kOut,   // out = S + L, S untouched (the last path feeds winner-takes-all directly)
};

// One path step: L(p,.) from L(p-r,.) (with kBig sentinels at index -1 and Dp).
// Returns min_k L(p,k).
template <Acc kAcc>
inline uint16_t Step(const uint8_t* C, const v16* bias, const uint16_t* Lprev, uint16_t min_prev, uint16_t p1,
                     uint16_t p2e, uint16_t* Lcur, uint16_t* S, int Dp, uint16_t* out = nullptr) {
  const v16 vp1 = Splat(p1), vmp2 = Splat(static_cast<uint16_t>(min_prev + p2e)), vmp = Splat(min_prev);
  v16 mn = Splat(0xFFFF);
  for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
    const v16 cost = LoadCost(C + j) + bias[c];
    const v16 near = VMin(Load(Lprev + j - 1), Load(Lprev + j + 1)) + vp1;
    const v16 t = VMin(VMin(Load(Lprev + j), near), vmp2);
    const v16 l = cost + t - vmp;
    Store(Lcur + j, l);
    if constexpr (kAcc == Acc::kInit) Store(S + j, l);
    if constexpr (kAcc == Acc::kAdd) Store(S + j, Load(S + j) + l);
    if constexpr (kAcc == Acc::kOut) Store(out + j, Load(S + j) + l);
    mn = VMin(mn, l);
  }
  return HMin(mn);
}

template <Acc kAcc>
inline uint16_t StepStart(const uint8_t* C, const v16* bias, uint16_t* Lcur, uint16_t* S, int Dp,
                          uint16_t* out = nullptr) {
  v16 mn = Splat(0xFFFF);
  for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
    const v16 l = LoadCost(C + j) + bias[c];
    Store(Lcur + j, l);
    if constexpr (kAcc == Acc::kInit) Store(S + j, l);
    if constexpr (kAcc == Acc::kAdd) Store(S + j, Load(S + j) + l);
    if constexpr (kAcc == Acc::kOut) Store(out + j, Load(S + j) + l);
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

// Winner-takes-all of one pixel from its summed costs S[0, Dp): uniqueness, sub-pixel; writes
// the disparity and validity before the left-right check and returns the winner k.
struct Wta {
  int W = 0, D = 0, Dp = 0, uniqueness = 0;
  SubpixelMode subpixel = SubpixelMode::kNone;
  std::vector<uint32_t> real;  // per chunk of kLanes disparities: lanes k < D
  uint64_t uniqueness_magic = 0;  // floor(2^40 / (100 - r)) + 1: division by 100 - r as a multiply
  Wta(const SgmParams& P, int width, int dp)
      : W(width), D(P.num_disparities), Dp(dp), uniqueness(P.uniqueness_ratio), subpixel(P.subpixel), real(dp / kLanes) {
    uniqueness_magic = (uint64_t{1} << 40) / static_cast<uint64_t>(100 - uniqueness) + 1;
    for (int c = 0; c < dp / kLanes; ++c)
      for (int i = 0; i < kLanes; ++i)
        if (c * kLanes + i < D) real[c] |= 1u << i;
  }
  // kDp: Dp known at compile time (loops unroll), or 0.
  template <int kDp = 0>
  int Pixel(const uint16_t* S, int u, int off, float* disp, uint8_t* valid) const {
    const int Dp = kDp ? kDp : this->Dp;
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
    bool ok = true;
    // Uniqueness: rejected when a real k with |k - b| > 1 has S(k) * (100 - r) < smin * 100, i.e.
    // S(k) <= thr = (smin * 100 - 1) / (100 - r) for smin > 0 (none qualifies when smin = 0).
    // Lane masks against one threshold keep this off the critical path of a second minimum.
    if (uniqueness > 0 && smin > 0) {
      // (smin * 100 - 1) / (100 - r) by a multiply: exact since x * (M * d - 2^40) < 2^40 here.
      const uint64_t x = static_cast<uint64_t>(smin) * 100 - 1;
      const int thr = static_cast<int>(std::min<uint64_t>(0xFFFF, (x * uniqueness_magic) >> 40));
      for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
        const int sh = b - 1 - j;  // lanes b-1..b+1 of this chunk are excluded
        const uint32_t near = sh >= 0 ? (sh < 32 ? 7u << sh : 0u) : (sh > -3 ? 7u >> -sh : 0u);
        if (LanesLe(Load(S + j), static_cast<uint16_t>(thr)) & real[c] & ~near) {
          ok = false;
          break;
        }
      }
    }
    const int x = u - off - b;
    if (x < 0 || x >= W) ok = false;
    float sub = 0.0f;
    if (ok && subpixel != SubpixelMode::kNone && b > 0 && b < D - 1) sub = SubpixelOffset(S[b - 1], S[b], S[b + 1], subpixel);
    *valid = ok ? 255 : 0;
    *disp = ok ? static_cast<float>(off + b) + sub : 0.0f;
    return b;
  }
};

// Right-view winners argmin_k S(x + off + k, k) (smallest k on ties) of one row, packed as
// S << 16 | k so that one unsigned minimum applies both rules. Pixels u are pushed in ascending
// order; a sliding window of Dp entries (lane j <-> target x = u - off - j) lives in registers,
// so no entry is stored and reloaded per pixel. Runs of pixels (column blocks) work
// independently: pushing u finishes target x = u - off - Dp as far as this run can see (row[x],
// a plain store: each x has exactly one such pixel), and Finish leaves the run's last Dp targets
// in edge[j] (x = u_last - off - j). A target's winner is the minimum of its row entry and, when
// it lies within Dp of a run's end, that run's edge entry (RightWinnerRows::At): order-independent,
// so deterministic, and no shared entry is written twice.
constexpr int kL32 = 16;
using v32 = uint32_t __attribute__((vector_size(4 * kL32)));
using m32 = uint32_t __attribute__((vector_size(4 * kL32)));
using v16h = uint16_t __attribute__((vector_size(2 * kL32)));
constexpr uint32_t kNoMatch = 0xFFFFFFFFu;

template <int kN = 0>  // kN: Dp / 16 known at compile time (the window stays in registers), or 0
class RightWinners {
 public:
  RightWinners(int D, int Dp) : n_(kN ? kN : Dp / kL32) {
    for (int c = 0; c < n_; ++c)
      for (int i = 0; i < kL32; ++i) {
        const int k = c * kL32 + i;
        key_[c][i] = k < D ? static_cast<uint32_t>(k) : kNoMatch;  // padded lanes never win
      }
  }
  // Starts a run at pixel u0 of a row: targets go to row (W entries), the run's end to edge (Dp).
  void Start(uint32_t* row, uint32_t* edge, int W, int u0, int off) {
    row_ = row, edge_ = edge, W_ = W, off_ = off, u_ = u0;
    for (int c = 0; c < n_; ++c) win_[c] = v32{} + kNoMatch;
  }
  // Adds pixel u_ (the next in the run) with summed costs S[0, Dp).
  void Push(const uint16_t* S) {
    const uint32_t done = win_[n_ - 1][kL32 - 1];  // target x = u_ - off - Dp: no later pixel reaches it
    constexpr m32 shift = {15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30};
    for (int c = n_ - 1; c >= 0; --c) win_[c] = __builtin_shuffle(c ? win_[c - 1] : v32{} + kNoMatch, win_[c], shift);
    for (int c = 0; c < n_; ++c) {
      v16h s;
      std::memcpy(&s, S + c * kL32, sizeof(s));
      const v32 packed = (__builtin_convertvector(s, v32) << 16) | key_[c];
      win_[c] = win_[c] < packed ? win_[c] : packed;
    }
    const int x = u_ - off_ - n_ * kL32;
    if (x >= 0 && x < W_) row_[x] = done;
    ++u_;
  }
  // Ends the run: lane j (target x = u_last - off - j) to edge[j].
  void Finish() {
    for (int c = 0; c < n_; ++c) std::memcpy(edge_ + c * kL32, &win_[c], sizeof(v32));
  }

 private:
  static constexpr int kMax = kN ? kN : 1024 / kL32;
  const int n_;
  std::array<v32, kMax> win_;
  std::array<v32, kMax> key_;
  uint32_t* row_ = nullptr;
  uint32_t* edge_ = nullptr;
  int W_ = 0, off_ = 0, u_ = 0;
};

// Where RightWinners left the rows: runs are column blocks [b * block, min(W, (b + 1) * block)),
// block >= Dp (only the last run, or a single one, may be narrower).
struct RightWinnerRows {
  const uint32_t* row;   // H x W
  const uint32_t* edge;  // H x blocks x Dp
  int W, Dp, blocks;
  // Per first candidate ux = x + off in [-Dp, W), at [ux + Dp]: up to two run-end entries
  // (b * Dp + j) holding some of the target's candidates, -1 if none. A table, not a division per pixel.
  std::vector<int> end1, end2;
  RightWinnerRows(const uint32_t* row_, const uint32_t* edge_, int W_, int Dp_, int block)
      : row(row_), edge(edge_), W(W_), Dp(Dp_), blocks((W_ + block - 1) / block), end1(W_ + Dp_, -1), end2(W_ + Dp_, -1) {
    for (int b = 0; b < blocks; ++b) {
      const int u1 = std::min(W, (b + 1) * block);
      for (int j = 0; j < Dp; ++j) {  // run b's lane j: ux = u1 - 1 - j
        const int i = u1 - 1 - j + Dp;
        if (i < 0) break;
        (end1[i] < 0 ? end1[i] : end2[i]) = b * Dp + j;
      }
    }
  }
  // Packed right-view winner of target x in row v (kNoMatch: no candidate inside the image).
  uint32_t At(int v, int x, int off) const {
    const int ux = x + off;  // the target's candidates are pixels ux .. ux + Dp - 1
    uint32_t best = ux + Dp >= 0 && ux + Dp < W ? row[static_cast<size_t>(v) * W + x] : kNoMatch;
    const uint32_t* e = edge + static_cast<size_t>(v) * blocks * Dp;
    if (const int i = end1[ux + Dp]; i >= 0) best = std::min(best, e[i]);
    if (const int i = end2[ux + Dp]; i >= 0) best = std::min(best, e[i]);
    return best;
  }
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

// Inputs of pass 1 (see ComputeSgm).
struct CostContext {
  const Volume& vol;
  const v16* bias;
  const Penalties& pen;
  const uint8_t* img;  // left image, W x H continuous
  const SgmParams& P;
  int W, H, D, Dp;
  const uint64_t* cl;  // census codes, left and right
  const uint64_t* cr;
  const cv::Mat& L;
  const cv::Mat& R;
  std::atomic<double>* cost_ms_total;
  int Offset(int v) const { return P.min_disparity + (P.row_offset.empty() ? 0 : P.row_offset[v]); }
  int I(int v, int u) const { return img[static_cast<size_t>(v) * W + u]; }
};

// Both horizontal paths of kNR rows from v0, advancing together (independent dependency chains).
template <int kNR>
inline void HorizontalRows(const CostContext& c, int v0, int dp, LineBuffer* buf) {
  const int W = c.W;
  uint16_t *prev[kNR], *cur[kNR];
  uint16_t mp[kNR];
  for (int i = 0; i < kNR; ++i) {
    prev[i] = buf->L(2 * i), cur[i] = buf->L(2 * i + 1);
    mp[i] = StepStart<Acc::kInit>(c.vol.Cost(v0 + i, 0), c.bias, prev[i], c.vol.Sum(v0 + i, 0), dp);
  }
  for (int u = 1; u < W; ++u)
    for (int i = 0; i < kNR; ++i) {
      const int v = v0 + i;
      mp[i] = Step<Acc::kInit>(c.vol.Cost(v, u), c.bias, prev[i], mp[i], c.pen.p1, c.pen.Eff(c.I(v, u), c.I(v, u - 1)),
                               cur[i], c.vol.Sum(v, u), dp);
      std::swap(prev[i], cur[i]);
    }
  for (int i = 0; i < kNR; ++i)
    mp[i] = StepStart<Acc::kAdd>(c.vol.Cost(v0 + i, W - 1), c.bias, prev[i], c.vol.Sum(v0 + i, W - 1), dp);
  for (int u = W - 2; u >= 0; --u)
    for (int i = 0; i < kNR; ++i) {
      const int v = v0 + i;
      mp[i] = Step<Acc::kAdd>(c.vol.Cost(v, u), c.bias, prev[i], mp[i], c.pen.p1, c.pen.Eff(c.I(v, u), c.I(v, u + 1)),
                              cur[i], c.vol.Sum(v, u), dp);
      std::swap(prev[i], cur[i]);
    }
}

// Pass 1: cost and horizontal paths, independent per row, in pairs of rows (a path step waits on
// the previous step's minimum, so one row alone leaves the core mostly idle). With
// `down`, the downward vertical path follows in the same TBB pipeline, in row order, on each row
// pair just finished: its cost and sums are still in cache, which saves a trip through memory
// over the whole volume. kNC as in VerticalPathsAndWta.
template <int kNC>
void CostAndHorizontalPaths(const CostContext& c, bool down) {
  constexpr int kRowsPerToken = 2;
  const int dp = kNC ? kNC * kLanes : c.Dp, W = c.W, H = c.H;
  int next = 0;
  LineBuffer la(W, dp), lb(W, dp);  // downward path: previous and current row
  auto horizontal = [&](int v0) {
    const int nr = std::min(kRowsPerToken, H - v0);
    LineBuffer buf(2 * kRowsPerToken, dp);
    std::vector<uint64_t> cr_rev(W);
    std::vector<uint8_t> ir_rev(W);
    const auto tc = std::chrono::steady_clock::now();
    for (int v = v0; v < v0 + nr; ++v) {
      const uint64_t* crow = c.cr + static_cast<size_t>(v) * W;
      const uint8_t* irow = c.R.ptr<uint8_t>(v);
      std::reverse_copy(crow, crow + W, cr_rev.begin());
      std::reverse_copy(irow, irow + W, ir_rev.begin());
      ComputeCostRow(c.P, c.cl + static_cast<size_t>(v) * W, cr_rev.data(), c.L.ptr<uint8_t>(v), ir_rev.data(), W, c.D,
                     dp, c.Offset(v), c.vol.cost.get() + static_cast<size_t>(v) * W * dp);
    }
    c.cost_ms_total->fetch_add(MsSince(tc));
    if (nr == kRowsPerToken) {
      HorizontalRows<kRowsPerToken>(c, v0, dp, &buf);
    } else {
      for (int v = v0; v < v0 + nr; ++v) HorizontalRows<1>(c, v, dp, &buf);
    }
    return v0;
  };
  auto downward = [&](int v0) {
    for (int v = v0; v < std::min(v0 + kRowsPerToken, H); ++v) {
      for (int u = 0; u < W; ++u)
        lb.min[u] = v == 0 ? StepStart<Acc::kAdd>(c.vol.Cost(v, u), c.bias, lb.L(u), c.vol.Sum(v, u), dp)
                           : Step<Acc::kAdd>(c.vol.Cost(v, u), c.bias, la.L(u), la.min[u], c.pen.p1,
                                             c.pen.Eff(c.I(v, u), c.I(v - 1, u)), lb.L(u), c.vol.Sum(v, u), dp);
      std::swap(la, lb);
    }
  };
  auto source = tbb::make_filter<void, int>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& fc) {
    if (next >= H) fc.stop();
    const int v0 = next;
    next += kRowsPerToken;
    return v0;
  });
  auto rows = tbb::make_filter<int, int>(tbb::filter_mode::parallel, horizontal);
  if (down) {
    tbb::parallel_pipeline(4, source & rows & tbb::make_filter<int, void>(tbb::filter_mode::serial_in_order, downward));
  } else {
    tbb::parallel_pipeline(8, source & rows & tbb::make_filter<int, void>(tbb::filter_mode::parallel, [](int) {}));
  }
}

// Inputs and outputs of the 4-path upward sweep (see ComputeSgm).
struct VerticalContext {
  const Volume& vol;
  const v16* bias;
  const Penalties& pen;
  const uint8_t* img;  // left image, W x H continuous
  const SgmParams& P;
  int W, H, D, Dp;
  bool lr;
  const Wta& wta;
  uint16_t* best;
  uint32_t* right;  // RightWinners rows, H x W
  uint32_t* edge;   // RightWinners run ends, H x blocks x Dp
  int block, blocks;  // column blocks [b * block, min(W, (b + 1) * block)), block >= Dp
  SgmOutput* out;
  int Offset(int v) const { return P.min_disparity + (P.row_offset.empty() ? 0 : P.row_offset[v]); }
  int I(int v, int u) const { return img[static_cast<size_t>(v) * W + u]; }
};

// Upward vertical path of the 4-path mode (the downward one runs in pass 1): columns are
// independent, so blocks of columns sweep the whole image without a barrier per row. It is the
// last path: it hands each pixel's final sums straight to winner-takes-all (and the right-view
// winners) instead of storing them.
// kNC: vectors per pixel when fixed at compile time (loops unroll, registers hold the window), or 0.
template <int kNC>
void VerticalPathsAndWta(const VerticalContext& c) {
  constexpr int kDp = kNC * kLanes;
  const int dp = kNC ? kDp : c.Dp, W = c.W, H = c.H;
  const Volume& vol = c.vol;
  tbb::parallel_for(0, c.blocks, [&](int blk) {
    const int u0 = blk * c.block, n = std::min(W, u0 + c.block) - u0;
    LineBuffer a(n, dp), b(n, dp);
    std::vector<uint16_t> sbuf(dp);
    uint16_t* s = sbuf.data();
    RightWinners<kDp / kL32> rw(c.D, dp);
    for (int v = H - 1; v >= 0; --v) {
      const int off = c.Offset(v);
      float* disp = c.out->disparity.ptr<float>(v);
      uint8_t* valid = c.out->valid.ptr<uint8_t>(v);
      uint16_t* bestv = c.best + static_cast<size_t>(v) * W;
      if (c.lr)
        rw.Start(c.right + static_cast<size_t>(v) * W, c.edge + (static_cast<size_t>(v) * c.blocks + blk) * dp, W, u0, off);
      const int vn = std::max(v - 1, 0);  // next row up: prefetched (rows are 80+ KB apart, beyond the streamers)
      for (int i = 0; i < n; ++i) {
        const int u = u0 + i;
        __builtin_prefetch(vol.Sum(vn, u));
        for (int j = 64 / sizeof(uint16_t); j < dp; j += 64 / sizeof(uint16_t)) __builtin_prefetch(vol.Sum(vn, u) + j);
        if (i % 2 == 0) __builtin_prefetch(vol.Cost(vn, u));
        for (int j = 64; j < dp; j += 64) __builtin_prefetch(vol.Cost(vn, u) + j);
        b.min[i] = v == H - 1 ? StepStart<Acc::kOut>(vol.Cost(v, u), c.bias, b.L(i), vol.Sum(v, u), dp, s)
                              : Step<Acc::kOut>(vol.Cost(v, u), c.bias, a.L(i), a.min[i], c.pen.p1,
                                                c.pen.Eff(c.I(v, u), c.I(v + 1, u)), b.L(i), vol.Sum(v, u), dp, s);
        bestv[u] = static_cast<uint16_t>(c.wta.template Pixel<kDp>(s, u, off, disp + u, valid + u));
        if (c.lr) rw.Push(s);
      }
      if (c.lr) rw.Finish();
      std::swap(a, b);
    }
  });
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

// Byte vectors for the census: 64 pixels of a row at once.
using vb = uint8_t __attribute__((vector_size(64)));

// Shuffle mask interleaving the kE-byte elements of two vectors: output element pairs
// (a[e], b[e]) for e in the lower (kHi = false) or upper half of the elements.
constexpr uint8_t InterleaveIndex(int e_bytes, bool hi, int i) {
  const int pair = i / (2 * e_bytes), within = i % (2 * e_bytes), e = pair + (hi ? 32 / e_bytes : 0);
  return static_cast<uint8_t>(within < e_bytes ? e * e_bytes + within : 64 + e * e_bytes + within - e_bytes);
}
template <int kE, bool kHi, size_t... I>
constexpr vb InterleaveMask(std::index_sequence<I...>) {
  return vb{InterleaveIndex(kE, kHi, static_cast<int>(I))...};
}
template <int kE, bool kHi>
inline vb Interleave(vb a, vb b) {
  constexpr vb mask = InterleaveMask<kE, kHi>(std::make_index_sequence<64>{});
  return __builtin_shuffle(a, b, mask);
}

// Census codes into `codes` (W*H). Bit-sliced: comparison i (window order, centre skipped) of
// n = width*height - 1 is code bit p = n-1-i; 64 pixels' bits for one code byte (p / 8) collect
// in a byte vector (one compare + and + or per comparison and 64 pixels), then 3 rounds of byte,
// 16-bit and 32-bit interleaving turn the 8 byte planes into 64 codes.
void CensusInto(const cv::Mat& gray8, int window_width, int window_height, uint64_t* codes) {
  const int W = gray8.cols, H = gray8.rows, rw = window_width / 2, rh = window_height / 2;
  const int n = window_width * window_height - 1;
  thread_local cv::Mat tls_padded;  // 64 extra columns on the right: a full vector can be read at every u < W
  cv::Mat& padded = tls_padded;     // (kept per calling thread: reused, no page faults per frame)
  cv::copyMakeBorder(gray8, padded, rh, rh, rw, rw + 64, cv::BORDER_REPLICATE);
  const ptrdiff_t stride = static_cast<ptrdiff_t>(padded.step);
  std::vector<ptrdiff_t> offsets;  // neighbour address - centre address, in comparison order
  for (int dy = -rh; dy <= rh; ++dy)
    for (int dx = -rw; dx <= rw; ++dx)
      if (dy != 0 || dx != 0) offsets.push_back(dy * stride + dx);
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 8), [&](const tbb::blocked_range<int>& r) {
    alignas(64) uint64_t tile[64];
    for (int v = r.begin(); v < r.end(); ++v) {
      for (int u0 = 0; u0 < W; u0 += 64) {
        const uint8_t* center = padded.ptr<uint8_t>(v + rh) + rw + u0;
        vb c;
        std::memcpy(&c, center, sizeof(c));
        vb plane[8] = {};
        int k = (n - 1) >> 3;
        vb acc = {};
        for (int i = 0; i < n; ++i) {
          const int p = n - 1 - i;
          if ((p >> 3) != k) plane[k] = acc, acc = vb{}, k = p >> 3;
          vb nb;
          std::memcpy(&nb, center + offsets[i], sizeof(nb));
          acc |= reinterpret_cast<vb>(nb < c) & static_cast<uint8_t>(1u << (p & 7));
        }
        plane[k] = acc;
        // Byte planes 0..7 (code byte 0 = least significant) -> little-endian uint64 per pixel.
        vb w16[8], w32[8], w64[8];
        for (int q = 0; q < 4; ++q)
          w16[2 * q] = Interleave<1, false>(plane[2 * q], plane[2 * q + 1]),
          w16[2 * q + 1] = Interleave<1, true>(plane[2 * q], plane[2 * q + 1]);
        // w16[2q + h]: pixels 32h..32h+31, bytes 2q, 2q+1.
        for (int h = 0; h < 2; ++h)
          for (int q = 0; q < 2; ++q) {
            const vb a = w16[4 * q + h], b = w16[4 * q + 2 + h];  // bytes 4q..4q+1 and 4q+2..4q+3
            w32[4 * q + 2 * h] = Interleave<2, false>(a, b), w32[4 * q + 2 * h + 1] = Interleave<2, true>(a, b);
          }
        // w32[4q + j]: pixels 16j..16j+15, bytes 4q..4q+3.
        for (int j = 0; j < 4; ++j) {
          w64[2 * j] = Interleave<4, false>(w32[j], w32[4 + j]);
          w64[2 * j + 1] = Interleave<4, true>(w32[j], w32[4 + j]);
        }
        // w64[m]: pixels 8m..8m+7.
        std::memcpy(tile, w64, sizeof(tile));
        const int count = std::min(64, W - u0);
        std::memcpy(codes + static_cast<size_t>(v) * W + u0, tile, count * sizeof(uint64_t));
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

  // Pass 1: cost and horizontal paths.
  t0 = std::chrono::steady_clock::now();
  std::atomic<double> cost_ms_total{0};
  {
    const CostContext ctx{vol, bias.data(), pen, img, P, W, H, D, Dp, cl.data(), cr.data(), L, R, &cost_ms_total};
    switch (nchunks) {
      case 1: CostAndHorizontalPaths<1>(ctx, P.num_paths == 4); break;
      case 2: CostAndHorizontalPaths<2>(ctx, P.num_paths == 4); break;
      case 3: CostAndHorizontalPaths<3>(ctx, P.num_paths == 4); break;
      case 4: CostAndHorizontalPaths<4>(ctx, P.num_paths == 4); break;
      default: CostAndHorizontalPaths<0>(ctx, P.num_paths == 4); break;
    }
  }

  // Right-view winners (left-right check) packed per target pixel, and the left winners.
  // Column blocks of the 4-path upward sweep (one run per row with 8 paths); every entry of
  // `right` and `edge` that RightWinner reads is written each frame, so neither is cleared.
  // Two blocks per thread (each thread sweeps a few wide blocks: finer blocks cost 1-2 ms CPU per
  // 1280x720 frame on 2 threads, in per-row overhead and shorter runs through memory), more
  // while a block's line buffers would pass ~64 KB, in steps of the thread count, so threads
  // stay balanced; at least Dp wide (RightWinnerRows). The result does not depend on the blocks.
  int block = W;
  if (P.num_paths == 4) {
    const int threads = std::max(1, tbb::this_task_arena::max_concurrency());
    const int cap = std::max(256, 32768 / Dp);
    for (int nb = 2 * threads;; nb += threads) {
      block = std::max(Dp, (W + nb - 1) / nb + 15) / 16 * 16;
      if (block <= cap || block <= Dp) break;
    }
  }
  const int blocks = (W + block - 1) / block;
  thread_local std::vector<uint32_t> tls_right, tls_edge;
  thread_local std::vector<uint16_t> tls_best;
  std::vector<uint32_t>& right = tls_right;
  std::vector<uint32_t>& edge = tls_edge;
  std::vector<uint16_t>& best = tls_best;
  const bool lr = P.lr_max_diff >= 0;
  if (lr) right.resize(static_cast<size_t>(W) * H), edge.resize(static_cast<size_t>(H) * blocks * Dp);
  best.resize(static_cast<size_t>(W) * H);
  out.disparity.create(H, W, CV_32F);
  out.valid.create(H, W, CV_8U);
  const Wta wta(P, W, Dp);
  double wta_ms = 0;

  if (P.num_paths == 4) {
    const VerticalContext ctx{vol,  bias.data(), pen,         img,   P,      W,   H, D, Dp, lr, wta, best.data(),
                              right.data(), edge.data(), block, blocks, &out};
    switch (nchunks) {
      case 1: VerticalPathsAndWta<1>(ctx); break;
      case 2: VerticalPathsAndWta<2>(ctx); break;
      case 3: VerticalPathsAndWta<3>(ctx); break;
      case 4: VerticalPathsAndWta<4>(ctx); break;
      default: VerticalPathsAndWta<0>(ctx); break;
    }
  } else {
    // With diagonals: sweep rows; each row's columns are independent given the previous row.
    const int dus[3] = {0, 1, -1};  // previous pixel column = u - du
    for (int sweep = 0; sweep < 2; ++sweep) {
      std::vector<LineBuffer> prevb, curb;
      for (int d = 0; d < 3; ++d) prevb.emplace_back(W, Dp), curb.emplace_back(W, Dp);
      for (int step = 0; step < H; ++step) {
        const int v = sweep == 0 ? step : H - 1 - step;
        const int vp = sweep == 0 ? v - 1 : v + 1;
        tbb::parallel_for(tbb::blocked_range<int>(0, W, 64), [&](const tbb::blocked_range<int>& r) {
          for (int u = r.begin(); u < r.end(); ++u) {
            for (int d = 0; d < 3; ++d) {
              const int up = u - dus[d];
              if (step == 0 || up < 0 || up >= W) {
                curb[d].min[u] = StepStart<Acc::kAdd>(vol.Cost(v, u), bias.data(), curb[d].L(u), vol.Sum(v, u), Dp);
              } else {
                curb[d].min[u] = Step<Acc::kAdd>(vol.Cost(v, u), bias.data(), prevb[d].L(up), prevb[d].min[up], pen.p1,
                                                 pen.Eff(I(v, u), I(vp, up)), curb[d].L(u), vol.Sum(v, u), Dp);
              }
            }
          }
        });
        std::swap(prevb, curb);
      }
    }
    const auto tw = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<int>(0, H, 4), [&](const tbb::blocked_range<int>& r) {
      RightWinners<> rw(D, Dp);
      for (int v = r.begin(); v < r.end(); ++v) {
        const int off = offset(v);
        float* disp = out.disparity.ptr<float>(v);
        uint8_t* valid = out.valid.ptr<uint8_t>(v);
        uint16_t* bestv = best.data() + static_cast<size_t>(v) * W;
        if (lr) rw.Start(right.data() + static_cast<size_t>(v) * W, edge.data() + static_cast<size_t>(v) * Dp, W, 0, off);
        for (int u = 0; u < W; ++u) {
          bestv[u] = static_cast<uint16_t>(wta.Pixel(vol.Sum(v, u), u, off, disp + u, valid + u));
          if (lr) rw.Push(vol.Sum(v, u));
        }
        if (lr) rw.Finish();
      }
    });
    wta_ms = MsSince(tw);
  }
  out.aggregation_ms = MsSince(t0) - wta_ms;
  out.cost_ms = cost_ms_total.load();

  // Left-right check: the right-view winner of the matched target pixel must agree.
  t0 = std::chrono::steady_clock::now();
  if (lr) {
    const RightWinnerRows winners(right.data(), edge.data(), W, Dp, block);
    tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
      for (int v = r.begin(); v < r.end(); ++v) {
        const int off = offset(v);
        float* disp = out.disparity.ptr<float>(v);
        uint8_t* valid = out.valid.ptr<uint8_t>(v);
        const uint16_t* bestv = best.data() + static_cast<size_t>(v) * W;
        for (int u = 0; u < W; ++u) {
          if (!valid[u]) continue;
          const uint32_t rx = winners.At(v, u - off - bestv[u], off);  // x in range: checked by Wta::Pixel
          if (rx == kNoMatch || std::abs(static_cast<int>(rx & 0xFFFF) - bestv[u]) > P.lr_max_diff)
            valid[u] = 0, disp[u] = 0.0f;
        }
      }
    });
  }
  out.wta_ms = wta_ms + MsSince(t0);
  return out;
}

}  // namespace rs
