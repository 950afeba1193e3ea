#pragma once
// Internal to the SGM core (sgm*.cc): the volume layout, the adaptive P2 table, the packed
// 4-path layout and the path step kernels (one pixel's L(p, .) from L(p - r, .)), with L in line
// buffers or in registers. Inline: each kernel must inline into its pass's loop.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include "stages/disparity/sgm.h"
#include "stages/disparity/sgm_simd.h"

namespace rs::sgm_detail {

struct Volume {
  int W = 0, H = 0, D = 0, Dp = 0;
  size_t cost_capacity = 0, sum_capacity = 0;  // elements allocated
  std::unique_ptr<uint8_t[]> cost;             // uninitialised on purpose: every element is written
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
  kInit,        // S = L
  kAdd,         // S += L
  kOut,         // out = S + L, S untouched (the last path feeds winner-takes-all directly)
  kPack,        // out = (S + L) | C << shift (PackedLayout: the sums of three paths and the cost in 16 bits)
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

}  // namespace rs::sgm_detail
