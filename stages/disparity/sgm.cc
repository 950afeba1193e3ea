// Optimised SGM. Layout: cost volume uint8 [v][u][Dp], aggregated sum uint16 [v][u][Dp],
// Dp = num_disparities rounded up to kLanes so one GCC vector (32 x uint16 = an AVX-512
// register where AVX512BW is enabled, else 16 x uint16 = AVX2; plain C++ lowers it elsewhere)
// covers kLanes disparities. Padded lanes carry a large bias so they never win a minimum; the
// bounds in SgmParams::Check keep every sum inside uint16. With 4 paths and small enough costs
// and P2 (PackedLayout, the defaults) the two volumes become one packed uint16 volume: the sum of
// three paths and the cost share 16 bits, and cost and sum rows only live in ring buffers.
//
// Passes (4 paths, the default): (1) a TBB pipeline over tokens of four rows: cost + both
// horizontal paths in parallel (initialises S; the four rows' path chains advance together with
// their L vectors in registers), then the downward path in row order while the rows are still in
// cache; (2) column blocks in parallel, rows bottom-up: the upward path, whose final sums go
// straight into winner-takes-all, uniqueness, sub-pixel and the right-view winners (never
// stored), two blocks per thread; (3) per row, in parallel: left-right check.
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
#include <new>
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
// Non-temporal store (p aligned to the vector size): no read-for-ownership of the line and no
// cache pollution, for volume rows that are read back only after ~all the others.
inline void StoreStream(uint16_t* p, v16 v) {
#if defined(__AVX512BW__)
  _mm512_stream_si512(reinterpret_cast<__m512i*>(p), reinterpret_cast<__m512i>(v));
#elif defined(__AVX2__)
  _mm256_stream_si256(reinterpret_cast<__m256i*>(p), reinterpret_cast<__m256i>(v));
#else
  Store(p, v);
#endif
}
inline void StreamFence() {
#if defined(__AVX2__)
  _mm_sfence();
#endif
}
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
  size_t cost_capacity = 0, sum_capacity = 0;  // elements allocated
  std::unique_ptr<uint8_t[]> cost;  // uninitialised on purpose: every element is written
  struct AlignedDelete {
    void operator()(uint16_t* p) const { ::operator delete[](p, std::align_val_t{64}); }
  };
  std::unique_ptr<uint16_t[], AlignedDelete> sum;  // 64-byte aligned (streaming stores)
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
  kPack,  // out = (S + L) | C << shift (PackedLayout: the sums of three paths and the cost in 16 bits)
  kPackStream,  // kPack with a non-temporal store
};

// Packed 4-path layout: after the horizontal and downward paths, S3 = L_lr + L_rl + L_down and the
// cost C of a (pixel, disparity) share one uint16, S3 in the low `shift` bits and C above, when
// both fit (each L <= MaxCost + P2, so S3 <= 3 * (MaxCost + P2)). The upward pass then streams
// 2 bytes per (pixel, disparity) instead of 3 (uint8 cost + uint16 sum volumes): a third less
// memory traffic in the passes that dominate the time. Padded lanes are masked to the S3 field
// (their cost bias comes back from `bias` in the upward pass).
struct PackedLayout {
  bool on = false;
  int shift = 0;  // bits of the S3 field
  uint16_t mask = 0;
  explicit PackedLayout(const SgmParams& P) {
    auto bits = [](int x) { return x > 0 ? 32 - __builtin_clz(static_cast<unsigned>(x)) : 0; };
    const int s3_bits = bits(3 * (P.MaxCost() + P.p2)), cost_bits = bits(P.MaxCost());
    on = P.num_paths == 4 && s3_bits + cost_bits <= 16;
    shift = s3_bits;
    mask = static_cast<uint16_t>((1u << s3_bits) - 1);
  }
};

// One path step: L(p,.) from L(p-r,.) (with kBig sentinels at index -1 and Dp).
// Returns min_k L(p,k).
// kPack: `out` gets the packed (S + L) & mask | C << shift (PackedLayout), S untouched.
template <Acc kAcc>
inline uint16_t Step(const uint8_t* C, const v16* bias, const uint16_t* Lprev, uint16_t min_prev, uint16_t p1,
                     uint16_t p2e, uint16_t* Lcur, uint16_t* S, int Dp, uint16_t* out = nullptr,
                     const PackedLayout* pk = nullptr) {
  const v16 vp1 = Splat(p1), vmp2 = Splat(static_cast<uint16_t>(min_prev + p2e)), vmp = Splat(min_prev);
  uint16_t mask = 0;
  int shift = 0;
  if constexpr (kAcc == Acc::kPack || kAcc == Acc::kPackStream) mask = pk->mask, shift = pk->shift;
  v16 mn = Splat(0xFFFF);
  for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
    const v16 raw = LoadCost(C + j);
    const v16 cost = raw + bias[c];
    const v16 near = VMin(Load(Lprev + j - 1), Load(Lprev + j + 1)) + vp1;
    const v16 t = VMin(VMin(Load(Lprev + j), near), vmp2);
    const v16 l = cost + t - vmp;
    Store(Lcur + j, l);
    if constexpr (kAcc == Acc::kInit) Store(S + j, l);
    if constexpr (kAcc == Acc::kAdd) Store(S + j, Load(S + j) + l);
    if constexpr (kAcc == Acc::kOut) Store(out + j, Load(S + j) + l);
    if constexpr (kAcc == Acc::kPack) Store(out + j, ((Load(S + j) + l) & mask) | (raw << shift));
    if constexpr (kAcc == Acc::kPackStream) StoreStream(out + j, ((Load(S + j) + l) & mask) | (raw << shift));
    mn = VMin(mn, l);
  }
  return HMin(mn);
}

template <Acc kAcc>
inline uint16_t StepStart(const uint8_t* C, const v16* bias, uint16_t* Lcur, uint16_t* S, int Dp,
                          uint16_t* out = nullptr, const PackedLayout* pk = nullptr) {
  v16 mn = Splat(0xFFFF);
  for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
    const v16 raw = LoadCost(C + j);
    const v16 l = raw + bias[c];
    Store(Lcur + j, l);
    if constexpr (kAcc == Acc::kInit) Store(S + j, l);
    if constexpr (kAcc == Acc::kAdd) Store(S + j, Load(S + j) + l);
    if constexpr (kAcc == Acc::kOut) Store(out + j, Load(S + j) + l);
    if constexpr (kAcc == Acc::kPack) Store(out + j, ((Load(S + j) + l) & pk->mask) | (raw << pk->shift));
    mn = VMin(mn, l);
  }
  return HMin(mn);
}

// The last (upward) path on the packed layout: cost and S3 unpacked from one uint16 vector,
// out = S3 + L (the final sums). kFirst: the first pixel of the path (L = C, Lprev unused).
template <bool kFirst>
inline uint16_t StepPackedOut(const uint16_t* Pk, const v16* bias, const uint16_t* Lprev, uint16_t min_prev,
                              uint16_t p1, uint16_t p2e, uint16_t* Lcur, int Dp, uint16_t* out,
                              const PackedLayout& pk) {
  const v16 vp1 = Splat(p1), vmp2 = Splat(static_cast<uint16_t>(min_prev + p2e)), vmp = Splat(min_prev);
  const int shift = pk.shift;
  const v16 mask = Splat(pk.mask);
  v16 mn = Splat(0xFFFF);
  for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) {
    const v16 x = Load(Pk + j);
    const v16 cost = (x >> shift) + bias[c];
    v16 l = cost;
    if constexpr (!kFirst) {
      const v16 near = VMin(Load(Lprev + j - 1), Load(Lprev + j + 1)) + vp1;
      const v16 t = VMin(VMin(Load(Lprev + j), near), vmp2);
      l = cost + t - vmp;
    }
    Store(Lcur + j, l);
    Store(out + j, (x & mask) + l);
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

// Winner-takes-all of one pixel from its summed costs S[0, Dp): uniqueness and the sub-pixel
// fraction's numerator and denominator; writes the validity before the left-right check and
// returns the winner k. The disparities of a run of pixels follow in Disparities (vectorised
// divisions: one scalar division per pixel cost as much as the rest of the winner search).
struct Wta {
  int W = 0, D = 0, Dp = 0, uniqueness = 0;
  SubpixelMode subpixel = SubpixelMode::kNone;
  std::vector<uint32_t> real;  // per chunk of kLanes disparities: lanes k < D
  uint64_t uniqueness_magic = 0;  // floor(2^40 / (100 - r)) + 1: division by 100 - r as a multiply
  // Keyed argmin: when S (<= 4 * (MaxCost + P2) with 4 paths) and k fit 16 bits together, one
  // minimum over S << key_bits | k gives the smallest S and, on ties, the smallest k (no
  // search for the first lane equal to the minimum on the critical path). Padded lanes are
  // clamped to the largest S field, above every real S, and lose ties by their larger k.
  int key_bits = 0;       // bits of k; 0 = keyed argmin off
  uint16_t key_cap = 0;   // largest S field value
  std::vector<v16> lane_k;  // per chunk: k of each lane
  Wta(const SgmParams& P, int width, int dp)
      : W(width), D(P.num_disparities), Dp(dp), uniqueness(P.uniqueness_ratio), subpixel(P.subpixel), real(dp / kLanes) {
    uniqueness_magic = (uint64_t{1} << 40) / static_cast<uint64_t>(100 - uniqueness) + 1;
    for (int c = 0; c < dp / kLanes; ++c)
      for (int i = 0; i < kLanes; ++i)
        if (c * kLanes + i < D) real[c] |= 1u << i;
    auto bits = [](int x) { return x > 0 ? 32 - __builtin_clz(static_cast<unsigned>(x)) : 0; };
    const int s_bits = bits(P.num_paths * (P.MaxCost() + P.p2)), k_bits = std::max(1, bits(dp - 1));
    if (s_bits + k_bits <= 16) {
      key_bits = k_bits;
      key_cap = static_cast<uint16_t>((1u << s_bits) - 1);
      for (int c = 0; c < dp / kLanes; ++c) {
        v16 k{};
        for (int i = 0; i < kLanes; ++i) k[i] = static_cast<uint16_t>(c * kLanes + i);
        lane_k.push_back(k);
      }
    }
  }
  // kDp: Dp known at compile time (loops unroll), or 0.
  template <int kDp = 0>
  int Pixel(const uint16_t* S, int u, int off, int* num, int* den, uint8_t* valid) const {
    const int Dp = kDp ? kDp : this->Dp;
    uint16_t smin = 0;
    int b = 0;
    if (key_bits) {
      const v16 cap = Splat(key_cap);
      v16 mn = Splat(0xFFFF);
      for (int j = 0, c = 0; j < Dp; j += kLanes, ++c) mn = VMin(mn, (VMin(Load(S + j), cap) << key_bits) | lane_k[c]);
      const uint16_t key = HMin(mn);
      smin = static_cast<uint16_t>(key >> key_bits), b = key & ((1 << key_bits) - 1);
    } else {
      v16 mn = Splat(0xFFFF);
      for (int j = 0; j < Dp; j += kLanes) mn = VMin(mn, Load(S + j));
      smin = HMin(mn);
      for (int j = 0; j < Dp; j += kLanes) {
        const int i = FirstEqual(Load(S + j), smin);
        if (i >= 0) {
          b = j + i;
          break;
        }
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
    // SubpixelOffset's num / den, or 0 / 1 where it is 0 (identical float result).
    int n = 0, d = 1;
    if (ok && subpixel != SubpixelMode::kNone && b > 0 && b < D - 1) {
      const int sm = S[b - 1], s0 = S[b], sp = S[b + 1];
      const int den = subpixel == SubpixelMode::kParabola ? 2 * (sm + sp - 2 * s0) : 2 * ((sm > sp ? sm : sp) - s0);
      if (den > 0) n = sm - sp, d = den;
    }
    *num = n, *den = d;
    *valid = ok ? 255 : 0;
    return b;
  }
  // disp = off + b + num / den where valid, else 0 (the shared definition's float arithmetic).
  static void Disparities(const uint16_t* __restrict best, const int* __restrict num, const int* __restrict den,
                          const uint8_t* __restrict valid, int off, int n, float* __restrict disp) {
    for (int i = 0; i < n; ++i) {
      const float d = static_cast<float>(off + best[i]) + static_cast<float>(num[i]) / static_cast<float>(den[i]);
      uint32_t bits;  // a bit mask, not a branch, so the loop vectorises (0 bits = +0.0f)
      std::memcpy(&bits, &d, sizeof(bits));
      bits &= 0u - static_cast<uint32_t>(valid[i] != 0);
      std::memcpy(disp + i, &bits, sizeof(bits));
    }
  }
};

// Right-view winners argmin_k S(x + off + k, k) (smallest k on ties) of one row, packed as
// S << 16 | k so that one unsigned minimum applies both rules. Pixels u are pushed in ascending
// order; a sliding window of Dp entries (lane j <-> target x = u - off - j) lives in registers,
// so no entry is stored and reloaded per pixel. Runs of pixels (column blocks) work
// independently: pushing u finishes target x = u - off - Dp as far as this run can see (row[x],
// a plain store: each x has exactly one such pixel), and Finish leaves the run's last Dp targets
// in edge[j] (x = u_last - off - j). A target's winner is the minimum of its row entry and, when
// it lies within Dp of a run's end, that run's edge entry (RightWinnerRows): order-independent,
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
  // Push for n pixels whose sums lie `stride` apart. With kN fixed the window is a local array
  // the compiler keeps in registers (the member array round-trips through memory every pixel,
  // a store-to-load chain from one pixel to the next).
  void PushRun(const uint16_t* S, int n, int stride) {
    if constexpr (kN == 0) {
      for (int i = 0; i < n; ++i) Push(S + static_cast<size_t>(i) * stride);
    } else {
      v32 w[kN], key[kN];
      for (int c = 0; c < kN; ++c) w[c] = win_[c], key[c] = key_[c];
      constexpr m32 shift = {15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30};
      int x = u_ - off_ - kN * kL32;
      for (int i = 0; i < n; ++i, ++x) {
        const uint16_t* Si = S + static_cast<size_t>(i) * stride;
        const uint32_t done = w[kN - 1][kL32 - 1];
        for (int c = kN - 1; c >= 0; --c) w[c] = __builtin_shuffle(c ? w[c - 1] : v32{} + kNoMatch, w[c], shift);
        for (int c = 0; c < kN; ++c) {
          v16h sv;
          std::memcpy(&sv, Si + c * kL32, sizeof(sv));
          const v32 packed = (__builtin_convertvector(sv, v32) << 16) | key[c];
          w[c] = w[c] < packed ? w[c] : packed;
        }
        if (x >= 0 && x < W_) row_[x] = done;
      }
      for (int c = 0; c < kN; ++c) win_[c] = w[c];
      u_ += n;
    }
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
  int W, Dp, blocks, block;
  RightWinnerRows(const uint32_t* row_, const uint32_t* edge_, int W_, int Dp_, int block_)
      : row(row_), edge(edge_), W(W_), Dp(Dp_), blocks((W_ + block_ - 1) / block_), block(block_) {}
  // Left-right check of row v: a valid pixel u (its target x = u - off - best[u] inside the image,
  // Wta::Pixel checked that) stays valid when the target's right-view winner is within
  // lr_max_diff of best[u]. The winners of the whole row are merged first into `win` (W entries):
  // a target's row entry (when the pixel x + off + Dp that finished it exists), then each run's
  // Dp end entries (lane j: target u1 - 1 - j - off) folded in by minimum; the check is then one
  // load per pixel. Everything in locals: the stores to valid and disp would otherwise make the
  // compiler reload the tables every pixel.
  void CheckRow(int v, int off, const uint16_t* __restrict best, int lr_max_diff, uint8_t* __restrict valid,
                float* __restrict disp, uint32_t* __restrict win) const {
    const uint32_t* __restrict rowv = row + static_cast<size_t>(v) * W;
    const uint32_t* __restrict e = edge + static_cast<size_t>(v) * blocks * Dp;
    const int w = W, dp = Dp;
    // Row entries exist for xl <= x < xr: the pixel x + off + Dp that finished them is in [0, W).
    const int xl = std::clamp(-off - dp, 0, w), xr = std::clamp(w - off - dp, xl, w);
    for (int x = 0; x < xl; ++x) win[x] = kNoMatch;
    for (int x = xl; x < xr; ++x) win[x] = rowv[x];
    for (int x = xr; x < w; ++x) win[x] = kNoMatch;
    for (int b = 0; b < blocks; ++b) {
      const int u1 = std::min(w, (b + 1) * block);
      for (int j = 0; j < dp; ++j) {
        const int x = u1 - 1 - j - off;
        if (x >= 0 && x < w) win[x] = std::min(win[x], e[b * dp + j]);
      }
    }
    for (int u = 0; u < w; ++u) {
      if (!valid[u]) continue;
      const int b = best[u];
      const uint32_t r = win[u - off - b];
      const int diff = static_cast<int>(r & 0xFFFF) - b;
      if (r == kNoMatch || diff > lr_max_diff || -diff > lr_max_diff) valid[u] = 0, disp[u] = 0.0f;
    }
  }
};

// cr_rev / ir_rev: the target row reversed (index W - 1 - x), so the candidates of one
// reference pixel, x = base - k, are a forward run in k and the popcounts vectorise.
// kDp: Dp known at compile time (0 = not): census-only pixels whose kDp candidates all lie in
// the image take a fixed-length loop (unrolled vector popcounts, no per-pixel loop bounds).
template <int kDp = 0>
void ComputeCostRow(const SgmParams& P, const uint64_t* __restrict cl, const uint64_t* __restrict cr_rev,
                    const uint8_t* __restrict il, const uint8_t* __restrict ir_rev, int W, int D, int Dp, int offset,
                    uint8_t* __restrict out) {
  const uint8_t max_cost = static_cast<uint8_t>(P.MaxCost());
  const int adw = P.ad_weight, adt = P.ad_truncation;
  for (int u = 0; u < W; ++u) {
    uint8_t* __restrict c = out + static_cast<size_t>(u) * Dp;
    const int base = u - offset;  // target column x = base - k must lie in [0, W)
    if constexpr (kDp > 0) {
      if (adw == 0 && base >= kDp - 1 && base <= W - 1) {
        const uint64_t code = cl[u];
        const uint64_t* __restrict cand = cr_rev + (W - 1 - base);
        for (int k = 0; k < kDp; ++k) c[k] = static_cast<uint8_t>(__builtin_popcountll(code ^ cand[k]));
        for (int k = D; k < kDp; ++k) c[k] = 0;  // padded lanes
        continue;
      }
    }
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

// Census transform of one image, by rows (defined with the census code below): Prepare pads the
// image and lists the window's neighbour offsets, Rows(v0, v1, codes) writes rows [v0, v1) of the
// W x H codes. Pass 1 runs it on each token's rows just before their cost, so the codes are
// consumed while in cache and the census needs no parallel loops of its own.
struct CensusPlan {
  const cv::Mat* padded = nullptr;  // 64 extra columns on the right: a full vector can be read at every u < W
  std::vector<ptrdiff_t> offsets;   // neighbour address - centre address, in comparison order
  int W = 0, n = 0, rw = 0, rh = 0;
  void Prepare(const cv::Mat& gray8, int window_width, int window_height, cv::Mat* storage);
  void Rows(int v0, int v1, uint64_t* codes) const;
};

// Inputs of pass 1 (see ComputeSgm).
struct CostContext {
  const Volume& vol;
  const v16* bias;
  const Penalties& pen;
  const uint8_t* img;  // left image, W x H continuous
  const SgmParams& P;
  int W, H, D, Dp;
  uint64_t* cl;  // census codes, left and right: computed per token from census_l / census_r
  uint64_t* cr;
  const CensusPlan& census_l;
  const CensusPlan& census_r;
  const cv::Mat& L;
  const cv::Mat& R;
  std::atomic<double>* cost_ms_total;
  const PackedLayout& pk;
  // Cost rows and sum rows: the volumes (ring = 0, row v at v), or with the packed layout ring
  // buffers of `ring` rows (row v at v % ring) that only live until the downward path has packed
  // them into vol.sum.
  uint8_t* cost_rows;
  uint16_t* sum_rows;
  int ring;
  int stream_rows;  // packed layout: rows above this one are stored non-temporally
  int Offset(int v) const { return P.min_disparity + (P.row_offset.empty() ? 0 : P.row_offset[v]); }
  int I(int v, int u) const { return img[static_cast<size_t>(v) * W + u]; }
  size_t Row(int v) const { return static_cast<size_t>(ring ? v % ring : v) * W; }
  uint8_t* Cost(int v, int u) const { return cost_rows + (Row(v) + u) * Dp; }
  uint16_t* Sum(int v, int u) const { return sum_rows + (Row(v) + u) * Dp; }
};

// Both horizontal paths of kNR rows from v0, advancing together (independent dependency chains),
// L in line buffers: the fallback for more than 4 vectors per pixel (HorizontalRowsReg otherwise).
template <int kNR>
inline void HorizontalRows(const CostContext& c, int v0, int dp, LineBuffer* buf) {
  const int W = c.W;
  uint16_t *prev[kNR], *cur[kNR];
  uint16_t mp[kNR];
  const uint8_t* crow[kNR];  // row starts, hoisted (the ring's row index is a modulo)
  uint16_t* srow[kNR];
  const uint8_t* irow[kNR];
  for (int i = 0; i < kNR; ++i) {
    crow[i] = c.Cost(v0 + i, 0), srow[i] = c.Sum(v0 + i, 0), irow[i] = c.img + static_cast<size_t>(v0 + i) * W;
    prev[i] = buf->L(2 * i), cur[i] = buf->L(2 * i + 1);
    mp[i] = StepStart<Acc::kInit>(crow[i], c.bias, prev[i], srow[i], dp);
  }
  for (int u = 1; u < W; ++u)
    for (int i = 0; i < kNR; ++i) {
      const size_t o = static_cast<size_t>(u) * dp;
      mp[i] = Step<Acc::kInit>(crow[i] + o, c.bias, prev[i], mp[i], c.pen.p1, c.pen.Eff(irow[i][u], irow[i][u - 1]),
                               cur[i], srow[i] + o, dp);
      std::swap(prev[i], cur[i]);
    }
  for (int i = 0; i < kNR; ++i) {
    const size_t o = static_cast<size_t>(W - 1) * dp;
    mp[i] = StepStart<Acc::kAdd>(crow[i] + o, c.bias, prev[i], srow[i] + o, dp);
  }
  for (int u = W - 2; u >= 0; --u)
    for (int i = 0; i < kNR; ++i) {
      const size_t o = static_cast<size_t>(u) * dp;
      mp[i] = Step<Acc::kAdd>(crow[i] + o, c.bias, prev[i], mp[i], c.pen.p1, c.pen.Eff(irow[i][u], irow[i][u + 1]),
                              cur[i], srow[i] + o, dp);
      std::swap(prev[i], cur[i]);
    }
}

// L(p, k -+ 1) of a register-held L(p, .) of kNC vectors: lanes shifted by one across the
// vectors, kBig outside [0, Dp) (the line buffers' sentinels).
using m16 = uint16_t __attribute__((vector_size(2 * kLanes)));
template <size_t... I>
constexpr m16 ShiftUpMask(std::index_sequence<I...>) {  // lane i <- (prev, cur)[i - 1]
  return m16{static_cast<uint16_t>(kLanes - 1 + I)...};
}
template <size_t... I>
constexpr m16 ShiftDownMask(std::index_sequence<I...>) {  // lane i <- (cur, next)[i + 1]
  return m16{static_cast<uint16_t>(I + 1)...};
}
template <int kNC>
inline void Neighbours(const v16 (&L)[kNC], v16 (&lo)[kNC], v16 (&hi)[kNC]) {
  constexpr m16 up = ShiftUpMask(std::make_index_sequence<kLanes>{});
  constexpr m16 down = ShiftDownMask(std::make_index_sequence<kLanes>{});
  const v16 big = Splat(kBig);
  for (int ch = 0; ch < kNC; ++ch) {
    lo[ch] = __builtin_shuffle(ch > 0 ? L[ch - 1] : big, L[ch], up);
    hi[ch] = __builtin_shuffle(L[ch], ch + 1 < kNC ? L[ch + 1] : big, down);
  }
}

// Step with L(p - r, .) and L(p, .) in registers: the horizontal paths' chains never wait on a
// store-to-load forward (the +-1 neighbours overlap two stored vectors, which no x86 forwards).
template <int kNC, Acc kAcc>
inline uint16_t StepReg(const uint8_t* C, const v16* bias, v16 (&L)[kNC], uint16_t min_prev, uint16_t p1, uint16_t p2e,
                        uint16_t* S) {
  const v16 vp1 = Splat(p1), vmp2 = Splat(static_cast<uint16_t>(min_prev + p2e)), vmp = Splat(min_prev);
  v16 lo[kNC], hi[kNC];
  Neighbours<kNC>(L, lo, hi);
  v16 mn = Splat(0xFFFF);
  for (int ch = 0; ch < kNC; ++ch) {
    const v16 cost = LoadCost(C + ch * kLanes) + bias[ch];
    const v16 t = VMin(VMin(L[ch], VMin(lo[ch], hi[ch]) + vp1), vmp2);
    L[ch] = cost + t - vmp;
    if constexpr (kAcc == Acc::kInit) Store(S + ch * kLanes, L[ch]);
    if constexpr (kAcc == Acc::kAdd) Store(S + ch * kLanes, Load(S + ch * kLanes) + L[ch]);
    mn = VMin(mn, L[ch]);
  }
  return HMin(mn);
}

template <int kNC, Acc kAcc>
inline uint16_t StepRegStart(const uint8_t* C, const v16* bias, v16 (&L)[kNC], uint16_t* S) {
  v16 mn = Splat(0xFFFF);
  for (int ch = 0; ch < kNC; ++ch) {
    L[ch] = LoadCost(C + ch * kLanes) + bias[ch];
    if constexpr (kAcc == Acc::kInit) Store(S + ch * kLanes, L[ch]);
    if constexpr (kAcc == Acc::kAdd) Store(S + ch * kLanes, Load(S + ch * kLanes) + L[ch]);
    mn = VMin(mn, L[ch]);
  }
  return HMin(mn);
}

// HorizontalRows with kNC (> 0) vectors per pixel held in registers.
template <int kNC, int kNR>
inline void HorizontalRowsReg(const CostContext& c, int v0) {
  constexpr int dp = kNC * kLanes;
  const int W = c.W;
  const uint16_t p1 = c.pen.p1;
  v16 L[kNR][kNC];
  uint16_t mp[kNR];
  const uint8_t* crow[kNR];
  uint16_t* srow[kNR];
  const uint8_t* irow[kNR];
  for (int i = 0; i < kNR; ++i) {
    crow[i] = c.Cost(v0 + i, 0), srow[i] = c.Sum(v0 + i, 0), irow[i] = c.img + static_cast<size_t>(v0 + i) * W;
    mp[i] = StepRegStart<kNC, Acc::kInit>(crow[i], c.bias, L[i], srow[i]);
  }
  for (int u = 1; u < W; ++u)
    for (int i = 0; i < kNR; ++i) {
      const size_t o = static_cast<size_t>(u) * dp;
      mp[i] = StepReg<kNC, Acc::kInit>(crow[i] + o, c.bias, L[i], mp[i], p1, c.pen.Eff(irow[i][u], irow[i][u - 1]),
                                       srow[i] + o);
    }
  for (int i = 0; i < kNR; ++i) {
    const size_t o = static_cast<size_t>(W - 1) * dp;
    mp[i] = StepRegStart<kNC, Acc::kAdd>(crow[i] + o, c.bias, L[i], srow[i] + o);
  }
  for (int u = W - 2; u >= 0; --u)
    for (int i = 0; i < kNR; ++i) {
      const size_t o = static_cast<size_t>(u) * dp;
      mp[i] = StepReg<kNC, Acc::kAdd>(crow[i] + o, c.bias, L[i], mp[i], p1, c.pen.Eff(irow[i][u], irow[i][u + 1]),
                                      srow[i] + o);
    }
}

// The upward path's step on the packed layout with L(p - r, .) loaded as whole aligned vectors and
// its +-1 neighbours made by lane shifts (Neighbours): the line buffer's unaligned +-1 loads split
// across cache lines on every pixel.
template <int kNC, bool kFirst>
inline uint16_t StepPackedOutReg(const uint16_t* Pk, const v16* bias, const v16* Lprev, uint16_t min_prev, uint16_t p1,
                                 uint16_t p2e, v16* Lcur, uint16_t* out, const PackedLayout& pk) {
  const v16 vp1 = Splat(p1), vmp2 = Splat(static_cast<uint16_t>(min_prev + p2e)), vmp = Splat(min_prev);
  const int shift = pk.shift;
  const v16 mask = Splat(pk.mask);
  v16 lp[kNC], lo[kNC], hi[kNC];
  if constexpr (!kFirst) {
    for (int ch = 0; ch < kNC; ++ch) lp[ch] = Lprev[ch];
    Neighbours<kNC>(lp, lo, hi);
  }
  v16 mn = Splat(0xFFFF);
  for (int ch = 0; ch < kNC; ++ch) {
    const v16 x = Load(Pk + ch * kLanes);
    const v16 cost = (x >> shift) + bias[ch];
    v16 l = cost;
    if constexpr (!kFirst) l = cost + VMin(VMin(lp[ch], VMin(lo[ch], hi[ch]) + vp1), vmp2) - vmp;
    Lcur[ch] = l;
    Store(out + ch * kLanes, (x & mask) + l);
    mn = VMin(mn, l);
  }
  return HMin(mn);
}

// The downward path's step into the packed volume, line buffers as whole vectors (as
// StepPackedOutReg). kStart: the first row (L = C).
template <int kNC, bool kStart, bool kStream>
inline uint16_t StepPackReg(const uint8_t* C, const v16* bias, const v16* Lprev, uint16_t min_prev, uint16_t p1,
                            uint16_t p2e, v16* Lcur, const uint16_t* S, uint16_t* out, const PackedLayout& pk) {
  const v16 vp1 = Splat(p1), vmp2 = Splat(static_cast<uint16_t>(min_prev + p2e)), vmp = Splat(min_prev);
  const int shift = pk.shift;
  const v16 mask = Splat(pk.mask);
  v16 lp[kNC], lo[kNC], hi[kNC];
  if constexpr (!kStart) {
    for (int ch = 0; ch < kNC; ++ch) lp[ch] = Lprev[ch];
    Neighbours<kNC>(lp, lo, hi);
  }
  v16 mn = Splat(0xFFFF);
  for (int ch = 0; ch < kNC; ++ch) {
    const v16 raw = LoadCost(C + ch * kLanes);
    v16 l = raw + bias[ch];
    if constexpr (!kStart) l = l + VMin(VMin(lp[ch], VMin(lo[ch], hi[ch]) + vp1), vmp2) - vmp;
    Lcur[ch] = l;
    const v16 packed = ((Load(S + ch * kLanes) + l) & mask) | (raw << shift);
    if constexpr (kStream) {
      StoreStream(out + ch * kLanes, packed);
    } else {
      Store(out + ch * kLanes, packed);
    }
    mn = VMin(mn, l);
  }
  return HMin(mn);
}

constexpr int kRowsPerToken = 4;  // four independent path chains per thread hide the step latency
// Tokens in flight in pass 1 with the downward path: one per thread, at least 2 (the serial
// downward stage overlaps the next token's horizontal paths); few, so that the packed layout's
// ring buffers (tokens * kRowsPerToken rows: at most that many tokens are in flight, so row v's
// slot is reused by row v + ring only after v is packed) stay small (2 tokens were 0.3-1 ms CPU
// per 1280x720 frame cheaper than 4 on 2 threads).
int PipelineTokens() { return std::clamp(tbb::this_task_arena::max_concurrency(), 2, 8); }

// Pass 1: cost and horizontal paths, independent per row, in pairs of rows (a path step waits on
// the previous step's minimum, so one row alone leaves the core mostly idle). With
// `down`, the downward vertical path follows in the same TBB pipeline, in row order, on each row
// pair just finished: its cost and sums are still in cache, which saves a trip through memory
// over the whole volume; with the packed layout it writes the packed volume (vol.sum), and cost
// and sums only ever live in the ring buffers. kNC as in VerticalPathsAndWta.
template <int kNC>
void CostAndHorizontalPaths(const CostContext& c, bool down) {
  const int dp = kNC ? kNC * kLanes : c.Dp, W = c.W, H = c.H;
  int next = 0;
  LineBuffer line[2] = {LineBuffer(W, dp), LineBuffer(W, dp)};  // downward path: rows by parity
  // The same as whole vectors for StepPackReg (packed layout, kNC fixed).
  const size_t vline_size = kNC > 0 && c.pk.on ? static_cast<size_t>(W) * kNC : 0;
  std::vector<v16> vline[2] = {std::vector<v16>(vline_size), std::vector<v16>(vline_size)};
  std::vector<uint16_t> vmin[2] = {std::vector<uint16_t>(W), std::vector<uint16_t>(W)};
  auto horizontal = [&](int v0) {
    const int nr = std::min(kRowsPerToken, H - v0);
    LineBuffer buf(2 * kRowsPerToken, dp);
    std::vector<uint64_t> cr_rev(W);
    std::vector<uint8_t> ir_rev(W);
    const auto tc = std::chrono::steady_clock::now();
    c.census_l.Rows(v0, v0 + nr, c.cl);
    c.census_r.Rows(v0, v0 + nr, c.cr);
    for (int v = v0; v < v0 + nr; ++v) {
      const uint64_t* crow = c.cr + static_cast<size_t>(v) * W;
      const uint8_t* irow = c.R.ptr<uint8_t>(v);
      std::reverse_copy(crow, crow + W, cr_rev.begin());
      std::reverse_copy(irow, irow + W, ir_rev.begin());
      ComputeCostRow<kNC * kLanes>(c.P, c.cl + static_cast<size_t>(v) * W, cr_rev.data(), c.L.ptr<uint8_t>(v),
                                   ir_rev.data(), W, c.D, dp, c.Offset(v), c.Cost(v, 0));
    }
    c.cost_ms_total->fetch_add(MsSince(tc));
    if constexpr (kNC > 0) {
      if (nr == kRowsPerToken) {
        HorizontalRowsReg<kNC, kRowsPerToken>(c, v0);
      } else {
        for (int v = v0; v < v0 + nr; ++v) HorizontalRowsReg<kNC, 1>(c, v);
      }
    } else if (nr == kRowsPerToken) {
      HorizontalRows<kRowsPerToken>(c, v0, dp, &buf);
    } else {
      for (int v = v0; v < v0 + nr; ++v) HorizontalRows<1>(c, v, dp, &buf);
    }
    return v0;
  };
  auto downward = [&](int v0) {
    for (int v = v0; v < std::min(v0 + kRowsPerToken, H); ++v) {
      LineBuffer& cur = line[v & 1];
      LineBuffer& prev = line[(v & 1) ^ 1];
      const uint8_t* crow = c.Cost(v, 0);  // row starts hoisted (the ring's row index is a modulo)
      uint16_t* srow = c.Sum(v, 0);
      const uint8_t* irow = c.img + static_cast<size_t>(v) * W;
      const uint8_t* iprev = v > 0 ? irow - W : irow;
      if (kNC > 0 && c.pk.on) {
        constexpr int kNCr = kNC > 0 ? kNC : 1;
        const PackedLayout pk = c.pk;  // a local copy: the stores below cannot alias it
        uint16_t* prow = c.vol.Sum(v, 0);
        v16* lc = vline[v & 1].data();
        const v16* lp = vline[(v & 1) ^ 1].data();
        uint16_t* mc = vmin[v & 1].data();
        const uint16_t* mp = vmin[(v & 1) ^ 1].data();
        const uint16_t p1 = c.pen.p1;
        for (int u = 0; u < W; ++u) {
          const size_t o = static_cast<size_t>(u) * dp, q = static_cast<size_t>(u) * kNCr;
          if (v == 0) {
            mc[u] = StepPackReg<kNCr, true, false>(crow + o, c.bias, nullptr, 0, 0, 0, lc + q, srow + o, prow + o, pk);
          } else if (v < c.stream_rows) {
            mc[u] = StepPackReg<kNCr, false, true>(crow + o, c.bias, lp + q, mp[u], p1, c.pen.Eff(irow[u], iprev[u]), lc + q,
                                                   srow + o, prow + o, pk);
          } else {
            mc[u] = StepPackReg<kNCr, false, false>(crow + o, c.bias, lp + q, mp[u], p1, c.pen.Eff(irow[u], iprev[u]),
                                                    lc + q, srow + o, prow + o, pk);
          }
        }
      } else if (c.pk.on) {
        const PackedLayout pk = c.pk;  // a local copy: the stores below cannot alias it
        uint16_t* prow = c.vol.Sum(v, 0);
        if (v == 0) {
          for (int u = 0; u < W; ++u) {
            const size_t o = static_cast<size_t>(u) * dp;
            cur.min[u] = StepStart<Acc::kPack>(crow + o, c.bias, cur.L(u), srow + o, dp, prow + o, &pk);
          }
        } else if (v < c.stream_rows) {
          for (int u = 0; u < W; ++u) {
            const size_t o = static_cast<size_t>(u) * dp;
            cur.min[u] = Step<Acc::kPackStream>(crow + o, c.bias, prev.L(u), prev.min[u], c.pen.p1,
                                                c.pen.Eff(irow[u], iprev[u]), cur.L(u), srow + o, dp, prow + o, &pk);
          }
        } else {
          for (int u = 0; u < W; ++u) {
            const size_t o = static_cast<size_t>(u) * dp;
            cur.min[u] = Step<Acc::kPack>(crow + o, c.bias, prev.L(u), prev.min[u], c.pen.p1,
                                          c.pen.Eff(irow[u], iprev[u]), cur.L(u), srow + o, dp, prow + o, &pk);
          }
        }
      } else {
        for (int u = 0; u < W; ++u) {
          const size_t o = static_cast<size_t>(u) * dp;
          cur.min[u] = v == 0 ? StepStart<Acc::kAdd>(crow + o, c.bias, cur.L(u), srow + o, dp)
                              : Step<Acc::kAdd>(crow + o, c.bias, prev.L(u), prev.min[u], c.pen.p1,
                                                c.pen.Eff(irow[u], iprev[u]), cur.L(u), srow + o, dp);
        }
      }
    }
    StreamFence();  // the streamed rows are complete before the upward pass (other threads) reads them
  };
  auto source = tbb::make_filter<void, int>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& fc) {
    if (next >= H) fc.stop();
    const int v0 = next;
    next += kRowsPerToken;
    return v0;
  });
  auto rows = tbb::make_filter<int, int>(tbb::filter_mode::parallel, horizontal);
  if (down) {
    tbb::parallel_pipeline(c.ring ? c.ring / kRowsPerToken : PipelineTokens(),
                           source & rows & tbb::make_filter<int, void>(tbb::filter_mode::serial_in_order, downward));
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
  const PackedLayout& pk;  // on: vol.sum holds the packed S3 | C (vol.cost unused)
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
    // Packed layout with kNC fixed: whole-vector line buffers (StepPackedOutReg).
    constexpr int kNCr = kNC > 0 ? kNC : 1;
    std::vector<v16> ra(c.pk.on && kNC > 0 ? static_cast<size_t>(n) * kNCr : 0), rb(ra.size());
    std::vector<uint16_t> sbuf(static_cast<size_t>(n) * dp);  // final sums of one block row
    uint16_t* s = sbuf.data();
    std::vector<int> num(n), den(n);  // sub-pixel fractions of one block row
    RightWinners<kDp / kL32> rw(c.D, dp);
    for (int v = H - 1; v >= 0; --v) {
      const int off = c.Offset(v);
      float* disp = c.out->disparity.ptr<float>(v);
      uint8_t* valid = c.out->valid.ptr<uint8_t>(v);
      uint16_t* bestv = c.best + static_cast<size_t>(v) * W;
      if (c.lr)
        rw.Start(c.right + static_cast<size_t>(v) * W, c.edge + (static_cast<size_t>(v) * c.blocks + blk) * dp, W, u0, off);
      const int vn = std::max(v - 1, 0);  // next row up: prefetched (rows are 80+ KB apart, beyond the streamers)
      // The block row's path steps first, then its winners: two short loop bodies of independent
      // pixels overlap in the out-of-order core far better than one long one.
      for (int i = 0; i < n; ++i) {
        const int u = u0 + i;
        uint16_t* si = s + static_cast<size_t>(i) * dp;
        __builtin_prefetch(vol.Sum(vn, u));
        for (int j = 64 / sizeof(uint16_t); j < dp; j += 64 / sizeof(uint16_t)) __builtin_prefetch(vol.Sum(vn, u) + j);
        if (kNC > 0 && c.pk.on) {
          v16* lb = rb.data() + static_cast<size_t>(i) * kNCr;
          b.min[i] = v == H - 1 ? StepPackedOutReg<kNCr, true>(vol.Sum(v, u), c.bias, nullptr, 0, 0, 0, lb, si, c.pk)
                                : StepPackedOutReg<kNCr, false>(vol.Sum(v, u), c.bias, ra.data() + static_cast<size_t>(i) * kNCr,
                                                                a.min[i], c.pen.p1, c.pen.Eff(c.I(v, u), c.I(v + 1, u)),
                                                                lb, si, c.pk);
        } else if (c.pk.on) {
          b.min[i] = v == H - 1 ? StepPackedOut<true>(vol.Sum(v, u), c.bias, nullptr, 0, 0, 0, b.L(i), dp, si, c.pk)
                                : StepPackedOut<false>(vol.Sum(v, u), c.bias, a.L(i), a.min[i], c.pen.p1,
                                                       c.pen.Eff(c.I(v, u), c.I(v + 1, u)), b.L(i), dp, si, c.pk);
        } else {
          if (i % 2 == 0) __builtin_prefetch(vol.Cost(vn, u));
          for (int j = 64; j < dp; j += 64) __builtin_prefetch(vol.Cost(vn, u) + j);
          b.min[i] = v == H - 1 ? StepStart<Acc::kOut>(vol.Cost(v, u), c.bias, b.L(i), vol.Sum(v, u), dp, si)
                                : Step<Acc::kOut>(vol.Cost(v, u), c.bias, a.L(i), a.min[i], c.pen.p1,
                                                  c.pen.Eff(c.I(v, u), c.I(v + 1, u)), b.L(i), vol.Sum(v, u), dp, si);
        }
      }
      for (int i = 0; i < n; ++i) {
        const int u = u0 + i;
        const uint16_t* si = s + static_cast<size_t>(i) * dp;
        bestv[u] = static_cast<uint16_t>(c.wta.template Pixel<kDp>(si, u, off, &num[i], &den[i], valid + u));
      }
      if (c.lr) rw.PushRun(s, n, dp);
      Wta::Disparities(bestv + u0, num.data(), den.data(), valid + u0, off, n, disp + u0);
      if (c.lr) rw.Finish();
      std::swap(a, b);
      std::swap(ra, rb);
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

// Census codes (W*H, by rows). Bit-sliced: comparison i (window order, centre skipped) of
// n = width*height - 1 is code bit p = n-1-i; 64 pixels' bits for one code byte (p / 8) collect
// in a byte vector (one compare + and + or per comparison and 64 pixels), then 3 rounds of byte,
// 16-bit and 32-bit interleaving turn the 8 byte planes into 64 codes.
void CensusPlan::Prepare(const cv::Mat& gray8, int window_width, int window_height, cv::Mat* storage) {
  W = gray8.cols, rw = window_width / 2, rh = window_height / 2, n = window_width * window_height - 1;
  cv::copyMakeBorder(gray8, *storage, rh, rh, rw, rw + 64, cv::BORDER_REPLICATE);
  padded = storage;
  const ptrdiff_t stride = static_cast<ptrdiff_t>(storage->step);
  offsets.clear();
  for (int dy = -rh; dy <= rh; ++dy)
    for (int dx = -rw; dx <= rw; ++dx)
      if (dy != 0 || dx != 0) offsets.push_back(dy * stride + dx);
}

void CensusPlan::Rows(int v0, int v1, uint64_t* codes) const {
  alignas(64) uint64_t tile[64];
  for (int v = v0; v < v1; ++v) {
    for (int u0 = 0; u0 < W; u0 += 64) {
      const uint8_t* center = padded->ptr<uint8_t>(v + rh) + rw + u0;
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
}

void CensusInto(const cv::Mat& gray8, int window_width, int window_height, uint64_t* codes) {
  thread_local cv::Mat tls_padded;  // kept per calling thread: reused, no page faults per frame
  CensusPlan plan;
  plan.Prepare(gray8, window_width, window_height, &tls_padded);
  tbb::parallel_for(tbb::blocked_range<int>(0, gray8.rows, 8),
                    [&](const tbb::blocked_range<int>& r) { plan.Rows(r.begin(), r.end(), codes); });
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
  thread_local cv::Mat tls_padded_l, tls_padded_r;
  CensusPlan census_l, census_r;  // the codes themselves are computed per token in pass 1
  census_l.Prepare(L, P.census_width, P.census_height, &tls_padded_l);
  census_r.Prepare(R, P.census_width, P.census_height, &tls_padded_r);
  out.census_ms = MsSince(t0);

  std::vector<v16> bias(nchunks, Splat(0));
  for (int k = D; k < Dp; ++k) bias[k / kLanes][k % kLanes] = kBig;
  const Penalties pen(P);

  // The volumes are kept per calling thread: re-faulting ~100 MB of fresh pages each frame costs
  // more than a frame's aggregation on small ranges.
  // (A named reference, so worker threads inside the lambdas see the caller's instance.)
  thread_local Volume tls_volume;
  Volume& vol = tls_volume;
  // Packed layout (4 paths, small costs and P2): no cost volume, cost and sum rows in rings.
  const PackedLayout pk(P);
  const size_t n = static_cast<size_t>(W) * H * Dp;
  if (n > vol.sum_capacity) {
    vol.sum.reset();
    vol.sum.reset(new (std::align_val_t{64}) uint16_t[n]);
    vol.sum_capacity = n;
  }
  if (!pk.on && n > vol.cost_capacity) {
    vol.cost.reset();
    vol.cost.reset(new uint8_t[n]);
    vol.cost_capacity = n;
  }
  vol.W = W, vol.H = H, vol.D = D, vol.Dp = Dp;
  thread_local std::vector<uint8_t> tls_cost_ring;
  thread_local std::vector<uint16_t> tls_sum_ring;
  const int ring_rows = PipelineTokens() * kRowsPerToken;
  std::vector<uint8_t>& cost_ring = tls_cost_ring;
  std::vector<uint16_t>& sum_ring = tls_sum_ring;
  if (pk.on) {
    cost_ring.resize(static_cast<size_t>(ring_rows) * W * Dp);
    sum_ring.resize(static_cast<size_t>(ring_rows) * W * Dp);
  }
  const uint8_t* img = L.ptr<uint8_t>(0);
  auto I = [&](int v, int u) -> int { return img[static_cast<size_t>(v) * W + u]; };

  // Packed rows above stream_rows bypass the caches (no read-for-ownership of ~60 MB); the last
  // ~8 MB stay cached, because the upward pass starts there.
  const int stream_rows = H - static_cast<int>((size_t{8} << 20) / (static_cast<size_t>(W) * Dp * sizeof(uint16_t)));

  // Pass 1: cost and horizontal paths.
  t0 = std::chrono::steady_clock::now();
  std::atomic<double> cost_ms_total{0};
  {
    const CostContext ctx{vol,
                          bias.data(),
                          pen,
                          img,
                          P,
                          W,
                          H,
                          D,
                          Dp,
                          cl.data(),
                          cr.data(),
                          census_l,
                          census_r,
                          L,
                          R,
                          &cost_ms_total,
                          pk,
                          pk.on ? cost_ring.data() : vol.cost.get(),
                          pk.on ? sum_ring.data() : vol.sum.get(),
                          pk.on ? ring_rows : 0,
                          stream_rows};
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
                              right.data(), edge.data(), block, blocks, &out, pk};
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
      std::vector<int> num(W), den(W);
      for (int v = r.begin(); v < r.end(); ++v) {
        const int off = offset(v);
        float* disp = out.disparity.ptr<float>(v);
        uint8_t* valid = out.valid.ptr<uint8_t>(v);
        uint16_t* bestv = best.data() + static_cast<size_t>(v) * W;
        if (lr) rw.Start(right.data() + static_cast<size_t>(v) * W, edge.data() + static_cast<size_t>(v) * Dp, W, 0, off);
        for (int u = 0; u < W; ++u) {
          bestv[u] = static_cast<uint16_t>(wta.Pixel(vol.Sum(v, u), u, off, &num[u], &den[u], valid + u));
          if (lr) rw.Push(vol.Sum(v, u));
        }
        Wta::Disparities(bestv, num.data(), den.data(), valid, off, W, disp);
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
      std::vector<uint32_t> win(W);
      for (int v = r.begin(); v < r.end(); ++v) {
        const int off = offset(v);
        float* disp = out.disparity.ptr<float>(v);
        uint8_t* valid = out.valid.ptr<uint8_t>(v);
        winners.CheckRow(v, off, best.data() + static_cast<size_t>(v) * W, P.lr_max_diff, valid, disp, win.data());
      }
    });
  }
  out.wta_ms = wta_ms + MsSince(t0);
  return out;
}

}  // namespace rs
