#pragma once
// Internal to the SGM core (sgm*.cc): winner-takes-all of one pixel (uniqueness, sub-pixel
// fraction), the right-view winners of a row (RightWinners) and the left-right check over them
// (RightWinnerRows). Inline: they run in the innermost loops of the last path.

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

#include "stages/disparity/sgm.h"
#include "stages/disparity/sgm_simd.h"

namespace rs::sgm_detail {

// Winner-takes-all of one pixel from its summed costs S[0, Dp): uniqueness and the sub-pixel
// fraction's numerator and denominator; writes the validity before the left-right check and
// returns the winner k. The disparities of a run of pixels follow in Disparities (vectorised
// divisions: one scalar division per pixel cost as much as the rest of the winner search).
struct Wta {
  int W = 0, D = 0, Dp = 0, uniqueness = 0;
  SubpixelMode subpixel = SubpixelMode::kNone;
  std::vector<uint32_t> real;     // per chunk of kLanes disparities: lanes k < D
  uint64_t uniqueness_magic = 0;  // floor(2^40 / (100 - r)) + 1: division by 100 - r as a multiply
  // Keyed argmin: when S (<= 4 * (MaxCost + P2) with 4 paths) and k fit 16 bits together, one
  // minimum over S << key_bits | k gives the smallest S and, on ties, the smallest k (no
  // search for the first lane equal to the minimum on the critical path). Padded lanes are
  // clamped to the largest S field, above every real S, and lose ties by their larger k.
  int key_bits = 0;         // bits of k; 0 = keyed argmin off
  uint16_t key_cap = 0;     // largest S field value
  std::vector<v16> lane_k;  // per chunk: k of each lane
  Wta(const SgmParams& P, int width, int dp)
      : W(width),
        D(P.num_disparities),
        Dp(dp),
        uniqueness(P.uniqueness_ratio),
        subpixel(P.subpixel),
        real(dp / kLanes) {
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

}  // namespace rs::sgm_detail
