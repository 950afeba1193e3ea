// SGM aggregation passes: cost rows, pass 1 (horizontal paths, downward path) and the 4-path
// upward path with winner-takes-all. Each pass and the step kernels it calls share this
// translation unit (kernels inline from sgm_steps.h / sgm_wta.h), instantiated per vector count.
#include "stages/disparity/sgm_passes.h"

#include <algorithm>
#include <cstdlib>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

namespace rs::sgm_detail {

int PipelineTokens() { return std::clamp(tbb::this_task_arena::max_concurrency(), 2, 8); }

namespace {

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

// CostAndHorizontalPaths (sgm_passes.h) with kNC as in VerticalPathsAndWtaFor.
template <int kNC>
void CostAndHorizontalPathsFor(const CostContext& c, bool down) {
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
            mc[u] = StepPackReg<kNCr, false, true>(crow + o, c.bias, lp + q, mp[u], p1, c.pen.Eff(irow[u], iprev[u]),
                                                   lc + q, srow + o, prow + o, pk);
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

// VerticalPathsAndWta (sgm_passes.h).
// kNC: vectors per pixel when fixed at compile time (loops unroll, registers hold the window), or 0.
template <int kNC>
void VerticalPathsAndWtaFor(const VerticalContext& c) {
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
        rw.Start(c.right + static_cast<size_t>(v) * W, c.edge + (static_cast<size_t>(v) * c.blocks + blk) * dp, W, u0,
                 off);
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
                                : StepPackedOutReg<kNCr, false>(
                                      vol.Sum(v, u), c.bias, ra.data() + static_cast<size_t>(i) * kNCr, a.min[i],
                                      c.pen.p1, c.pen.Eff(c.I(v, u), c.I(v + 1, u)), lb, si, c.pk);
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

void CostAndHorizontalPaths(const CostContext& c, bool down) {
  switch (c.Dp / kLanes) {
    case 1: CostAndHorizontalPathsFor<1>(c, down); break;
    case 2: CostAndHorizontalPathsFor<2>(c, down); break;
    case 3: CostAndHorizontalPathsFor<3>(c, down); break;
    case 4: CostAndHorizontalPathsFor<4>(c, down); break;
    default: CostAndHorizontalPathsFor<0>(c, down); break;
  }
}

void VerticalPathsAndWta(const VerticalContext& c) {
  switch (c.Dp / kLanes) {
    case 1: VerticalPathsAndWtaFor<1>(c); break;
    case 2: VerticalPathsAndWtaFor<2>(c); break;
    case 3: VerticalPathsAndWtaFor<3>(c); break;
    case 4: VerticalPathsAndWtaFor<4>(c); break;
    default: VerticalPathsAndWtaFor<0>(c); break;
  }
}

}  // namespace rs::sgm_detail
