#pragma once
// Internal to the SGM core (sgm*.cc): the aggregation passes that ComputeSgm runs, with their
// inputs: pass 1 (census rows, cost, horizontal paths and, with 4 paths, the downward path) and
// the 4-path upward path fused with winner-takes-all. Defined in sgm_passes.cc.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>

#include <opencv2/core/mat.hpp>

#include "stages/disparity/sgm.h"
#include "stages/disparity/sgm_census.h"
#include "stages/disparity/sgm_simd.h"
#include "stages/disparity/sgm_steps.h"
#include "stages/disparity/sgm_wta.h"
#include "survey/elapsed.h"

namespace rs::sgm_detail {

constexpr int kRowsPerToken = 4;  // four independent path chains per thread hide the step latency
// Tokens in flight in pass 1 with the downward path: one per thread, at least 2 (the serial
// downward stage overlaps the next token's horizontal paths); few, so that the packed layout's
// ring buffers (tokens * kRowsPerToken rows: at most that many tokens are in flight, so row v's
// slot is reused by row v + ring only after v is packed) stay small.
int PipelineTokens();

// What both passes read (see ComputeSgm).
struct PassInputs {
  const Volume& vol;
  const v16* bias;
  const Penalties& pen;
  const uint8_t* img;  // left image, W x H continuous
  const SgmParams& P;
  int W, H, D, Dp;
  int Offset(int v) const { return P.min_disparity + (P.row_offset.empty() ? 0 : P.row_offset[v]); }
  int I(int v, int u) const { return img[static_cast<size_t>(v) * W + u]; }
};

// Inputs of pass 1.
struct CostContext : PassInputs {
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
  size_t Row(int v) const { return static_cast<size_t>(ring ? v % ring : v) * W; }
  uint8_t* Cost(int v, int u) const { return cost_rows + (Row(v) + u) * Dp; }
  uint16_t* Sum(int v, int u) const { return sum_rows + (Row(v) + u) * Dp; }
};

// Inputs and outputs of the 4-path upward sweep.
struct VerticalContext : PassInputs {
  bool lr;
  const Wta& wta;
  uint16_t* best;
  uint32_t* right;    // RightWinners rows, H x W
  uint32_t* edge;     // RightWinners run ends, H x blocks x Dp
  int block, blocks;  // column blocks [b * block, min(W, (b + 1) * block)), block >= Dp
  SgmOutput* out;
  const PackedLayout& pk;  // on: vol.sum holds the packed S3 | C (vol.cost unused)
};

// Pass 1: cost and horizontal paths, independent per row, in pairs of rows (a path step waits on
// the previous step's minimum, so one row alone leaves the core mostly idle). With
// `down`, the downward vertical path follows in the same TBB pipeline, in row order, on each row
// pair just finished: its cost and sums are still in cache, which saves a trip through memory
// over the whole volume; with the packed layout it writes the packed volume (vol.sum), and cost
// and sums only ever live in the ring buffers. Specialised on Dp / kLanes (1-4 vectors per pixel, else generic).
void CostAndHorizontalPaths(const CostContext& c, bool down);

// Upward vertical path of the 4-path mode (the downward one runs in pass 1): columns are
// independent, so blocks of columns sweep the whole image without a barrier per row. It is the
// last path: it hands each pixel's final sums straight to winner-takes-all (and the right-view
// winners) instead of storing them.
// Specialised on Dp / kLanes as CostAndHorizontalPaths.
void VerticalPathsAndWta(const VerticalContext& c);

}  // namespace rs::sgm_detail
