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
  if (census_width < 1 || census_width % 2 == 0) fail("census_width = " + cw + " violates census_width odd and >= 1");
  if (census_height < 1 || census_height % 2 == 0)
    fail("census_height = " + ch + " violates census_height odd and >= 1");
  if (census_width * census_height < 9 || census_width * census_height > 65)
    fail("census window " + cw + "x" + ch + " violates 9 <= width*height <= 65 (64-bit codes)");
  if (ad_weight < 0) fail("ad_weight = " + std::to_string(ad_weight) + " violates ad_weight >= 0");
  if (ad_truncation < 1) fail("ad_truncation = " + std::to_string(ad_truncation) + " violates ad_truncation >= 1");
  if (MaxCost() > 255)
    fail("max cost " + std::to_string(MaxCost()) + " violates census bits + ad_weight*ad_truncation <= 255");
  if (num_paths != 4 && num_paths != 8)
    fail("num_paths = " + std::to_string(num_paths) + " violates num_paths in {4, 8}");
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

namespace {

// Scratch kept per calling thread and reused across frames: re-faulting ~100 MB of fresh pages
// each frame costs more than a frame's aggregation on small ranges. Callers bind named references
// to its members, so worker threads inside the lambdas see the caller's instance.
struct SgmScratch {
  std::vector<uint64_t> cl, cr;       // census codes, left and right
  cv::Mat padded_l, padded_r;         // the census plans' bordered images
  Volume volume;                      // cost and sum volumes
  std::vector<uint8_t> cost_ring;     // packed layout: cost rows in flight
  std::vector<uint16_t> sum_ring;     // packed layout: sum rows in flight
  std::vector<uint32_t> right, edge;  // right-view winners and their run ends
  std::vector<uint16_t> best;         // left winners
};

SgmScratch& ThreadScratch() {
  thread_local SgmScratch scratch;
  return scratch;
}

// Sizes the volumes and, with the packed layout, the ring buffers for a W x H x Dp frame: the
// packed layout (4 paths, small costs and P2) has no cost volume, cost and sum rows in rings.
// Returns the ring's rows.
int PrepareVolumes(SgmScratch& s, const PackedLayout& pk, int W, int H, int D, int Dp) {
  Volume& vol = s.volume;
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
  const int ring_rows = PipelineTokens() * kRowsPerToken;
  if (pk.on) {
    s.cost_ring.resize(static_cast<size_t>(ring_rows) * W * Dp);
    s.sum_ring.resize(static_cast<size_t>(ring_rows) * W * Dp);
  }
  return ring_rows;
}

// Width of the column blocks of the 4-path upward sweep (W with 8 paths: one run per row).
// Two blocks per thread (each thread sweeps a few wide blocks: finer blocks add per-row overhead
// and shorter runs through memory), more while a block's line buffers would pass ~64 KB, in
// steps of the thread count, so threads stay balanced; at least Dp wide (RightWinnerRows). The
// result does not depend on the blocks.
int ColumnBlockWidth(const SgmParams& P, int W, int Dp) {
  int block = W;
  if (P.num_paths == 4) {
    const int threads = std::max(1, tbb::this_task_arena::max_concurrency());
    const int cap = std::max(256, 32768 / Dp);
    for (int nb = 2 * threads;; nb += threads) {
      block = std::max(Dp, (W + nb - 1) / nb + 15) / 16 * 16;
      if (block <= cap || block <= Dp) break;
    }
  }
  return block;
}

// 8 paths: the vertical and diagonal paths complete S. Rows are swept top-down, then bottom-up;
// each row's columns are independent given the previous row.
void EightPathSweeps(const PassInputs& in) {
  const Volume& vol = in.vol;
  const int W = in.W, H = in.H, Dp = in.Dp;
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
              curb[d].min[u] = StepStart<Acc::kAdd>(vol.Cost(v, u), in.bias, curb[d].L(u), vol.Sum(v, u), Dp);
            } else {
              curb[d].min[u] = Step<Acc::kAdd>(vol.Cost(v, u), in.bias, prevb[d].L(up), prevb[d].min[up], in.pen.p1,
                                               in.pen.Eff(in.I(v, u), in.I(vp, up)), curb[d].L(u), vol.Sum(v, u), Dp);
            }
          }
        }
      });
      std::swap(prevb, curb);
    }
  }
}

// 8 paths: winner-takes-all per row over the completed sums, and the right-view winners for the
// left-right check when `right` is set.
void EightPathWta(const PassInputs& in, const Wta& wta, uint16_t* best, uint32_t* right, uint32_t* edge,
                  SgmOutput* out) {
  const Volume& vol = in.vol;
  const int W = in.W, H = in.H, D = in.D, Dp = in.Dp;
  const bool lr = right != nullptr;
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 4), [&](const tbb::blocked_range<int>& r) {
    RightWinners<> rw(D, Dp);
    std::vector<int> num(W), den(W);
    for (int v = r.begin(); v < r.end(); ++v) {
      const int off = in.Offset(v);
      float* disp = out->disparity.ptr<float>(v);
      uint8_t* valid = out->valid.ptr<uint8_t>(v);
      uint16_t* bestv = best + static_cast<size_t>(v) * W;
      if (lr) rw.Start(right + static_cast<size_t>(v) * W, edge + static_cast<size_t>(v) * Dp, W, 0, off);
      for (int u = 0; u < W; ++u) {
        bestv[u] = static_cast<uint16_t>(wta.Pixel(vol.Sum(v, u), u, off, &num[u], &den[u], valid + u));
        if (lr) rw.Push(vol.Sum(v, u));
      }
      Wta::Disparities(bestv, num.data(), den.data(), valid, off, W, disp);
      if (lr) rw.Finish();
    }
  });
}

// Left-right check: the right-view winner of the matched target pixel must agree.
void LeftRightCheck(const PassInputs& in, const RightWinnerRows& winners, const uint16_t* best, SgmOutput* out) {
  const int W = in.W, H = in.H;
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    std::vector<uint32_t> win(W);
    for (int v = r.begin(); v < r.end(); ++v) {
      const int off = in.Offset(v);
      float* disp = out->disparity.ptr<float>(v);
      uint8_t* valid = out->valid.ptr<uint8_t>(v);
      winners.CheckRow(v, off, best + static_cast<size_t>(v) * W, in.P.lr_max_diff, valid, disp, win.data());
    }
  });
}

}  // namespace

SgmOutput ComputeSgm(const cv::Mat& left_gray8, const cv::Mat& right_gray8, const SgmParams& P) {
  if (left_gray8.type() != CV_8UC1 || right_gray8.type() != CV_8UC1 || left_gray8.size() != right_gray8.size() ||
      left_gray8.empty())
    throw std::invalid_argument("sgm: inputs must be non-empty CV_8UC1 images of equal size");
  P.Check(left_gray8.rows);
  const cv::Mat L = left_gray8.isContinuous() ? left_gray8 : left_gray8.clone();
  const cv::Mat R = right_gray8.isContinuous() ? right_gray8 : right_gray8.clone();
  const int W = L.cols, H = L.rows, D = P.num_disparities, Dp = (D + kLanes - 1) / kLanes * kLanes,
            nchunks = Dp / kLanes;
  SgmOutput out;
  SgmScratch& scratch = ThreadScratch();

  auto t0 = std::chrono::steady_clock::now();
  std::vector<uint64_t>& cl = scratch.cl;
  std::vector<uint64_t>& cr = scratch.cr;
  cl.resize(L.total()), cr.resize(R.total());
  CensusPlan census_l, census_r;  // the codes themselves are computed per token in pass 1
  census_l.Prepare(L, P.census_width, P.census_height, &scratch.padded_l);
  census_r.Prepare(R, P.census_width, P.census_height, &scratch.padded_r);
  out.census_ms = MsSince(t0);

  std::vector<v16> bias(nchunks, Splat(0));
  for (int k = D; k < Dp; ++k) bias[k / kLanes][k % kLanes] = kBig;
  const Penalties pen(P);
  const PackedLayout pk(P);
  const int ring_rows = PrepareVolumes(scratch, pk, W, H, D, Dp);
  Volume& vol = scratch.volume;
  const uint8_t* img = L.ptr<uint8_t>(0);

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
                          pk.on ? scratch.cost_ring.data() : vol.cost.get(),
                          pk.on ? scratch.sum_ring.data() : vol.sum.get(),
                          pk.on ? ring_rows : 0,
                          stream_rows};
    CostAndHorizontalPaths(ctx, P.num_paths == 4);  // specialised on nchunks inside
  }

  // Right-view winners (left-right check) packed per target pixel, and the left winners. Every
  // entry of `right` and `edge` that RightWinner reads is written each frame, so neither is cleared.
  const int block = ColumnBlockWidth(P, W, Dp);
  const int blocks = (W + block - 1) / block;
  std::vector<uint32_t>& right = scratch.right;
  std::vector<uint32_t>& edge = scratch.edge;
  std::vector<uint16_t>& best = scratch.best;
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
    EightPathSweeps(in);
    const auto tw = std::chrono::steady_clock::now();
    EightPathWta(in, wta, best.data(), lr ? right.data() : nullptr, lr ? edge.data() : nullptr, &out);
    wta_ms = MsSince(tw);
  }
  out.aggregation_ms = MsSince(t0) - wta_ms;
  out.cost_ms = cost_ms_total.load();

  t0 = std::chrono::steady_clock::now();
  if (lr) LeftRightCheck(in, RightWinnerRows(right.data(), edge.data(), W, Dp, block), best.data(), &out);
  out.wta_ms = wta_ms + MsSince(t0);
  return out;
}

}  // namespace rs
