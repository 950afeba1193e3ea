// Census transform: CensusPlan (bit-sliced, 64 pixels of a row at once), CensusInto and the
// public CensusTransform.
#include "stages/disparity/sgm_census.h"

#include <algorithm>
#include <cstring>
#include <utility>

#include <opencv2/core.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "stages/disparity/sgm.h"

namespace rs {
namespace sgm_detail {
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

}  // namespace

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

}  // namespace sgm_detail

std::vector<uint64_t> CensusTransform(const cv::Mat& gray8, int window_width, int window_height) {
  std::vector<uint64_t> codes(gray8.total());
  sgm_detail::CensusInto(gray8, window_width, window_height, codes.data());
  return codes;
}

}  // namespace rs
