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
//
// Files: sgm_simd.h (vector types and helpers), sgm_steps.h (volume layout, penalties, path step
// kernels), sgm_wta.h (winner-takes-all, right-view winners, left-right check), sgm_census.{h,cc}
// (census transform), sgm_passes.{h,cc} (cost + pass 1, the 4-path upward pass); this file:
// SgmParams and ComputeSgm (set-up, the 8-path sweeps, the left-right check pass).
#include "stages/disparity/sgm.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "stages/disparity/sgm_passes.h"

namespace rs {

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

using namespace sgm_detail;  // the internal SGM types and kernels (sgm_*.h)

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

  const PassInputs in{vol, bias.data(), pen, img, P, W, H, D, Dp};

  // Pass 1: cost and horizontal paths.
  t0 = std::chrono::steady_clock::now();
  std::atomic<double> cost_ms_total{0};
  {
    const CostContext ctx{in,
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
    CostAndHorizontalPaths(ctx, P.num_paths == 4);  // specialised on nchunks inside
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
    const VerticalContext ctx{in, lr, wta, best.data(), right.data(), edge.data(), block, blocks, &out, pk};
    VerticalPathsAndWta(ctx);  // specialised on nchunks inside
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
