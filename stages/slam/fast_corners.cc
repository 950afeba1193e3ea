// FAST-9/16 as one branch-free u8 pass per vector of pixels, then non-maximum suppression on the score rows.
//
// With darkness_i = sat(c - p_i) and brightness_i = sat(p_i - c) over the 16 circle pixels, let A (B) be the
// largest minimum of darkness (brightness) over the 16 cyclic arcs of 9. The pixel is a corner iff
// max(A, B) > threshold, and OpenCV's cornerScore<16> is then max(A, B) - 1 (the largest threshold at which
// it is still a corner). Arc minima come from doubling: arcs of 2, 4, 8, then 8 plus the ninth pixel.

#include "stages/slam/fast_corners.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "stages/slam/highway_targets.h"
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "stages/slam/fast_corners.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace rs {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The radius-3 Bresenham circle as (dx, dy), in OpenCV's cyclic order.
constexpr int kCircle[16][2] = {{0, 3},  {1, 3},   {2, 2},   {3, 1},   {3, 0},  {3, -1}, {2, -2}, {1, -3},
                                {0, -3}, {-1, -3}, {-2, -2}, {-3, -1}, {-3, 0}, {-3, 1}, {-2, 2}, {-1, 3}};

// Score of one pixel (0 when not a corner), for rows narrower than a vector.
uint8_t ScalarScore(const uint8_t* p, const ptrdiff_t* ofs, int threshold) {
  int best_dark = 0, best_bright = 0;
  for (int i = 0; i < 16; ++i) {
    int dark = 255, bright = 255;
    for (int k = 0; k < 9; ++k) {
      const int v = p[ofs[(i + k) & 15]] - p[0];
      dark = std::min(dark, std::max(-v, 0));
      bright = std::min(bright, std::max(v, 0));
    }
    best_dark = std::max(best_dark, dark);
    best_bright = std::max(best_bright, bright);
  }
  const int m = std::max(best_dark, best_bright);
  return m > threshold ? static_cast<uint8_t>(m - 1) : 0;
}

// Largest minimum over the 16 cyclic arcs of 9 of x[0..15].
template <class V>
HWY_INLINE V MaxArcMin(const V* x) {
  V m2[16], m4[16];
  for (int i = 0; i < 16; ++i) m2[i] = hn::Min(x[i], x[(i + 1) & 15]);
  for (int i = 0; i < 16; ++i) m4[i] = hn::Min(m2[i], m2[(i + 2) & 15]);
  V best = hn::Min(hn::Min(m4[0], m4[4]), x[8]);
  for (int i = 1; i < 16; ++i) best = hn::Max(best, hn::Min(hn::Min(m4[i], m4[(i + 4) & 15]), x[(i + 8) & 15]));
  return best;
}

// Scores of the Lanes(d) pixels starting at p (0 where not a corner).
template <class D>
HWY_INLINE hn::Vec<D> VectorScore(D d, const uint8_t* p, const ptrdiff_t* ofs, hn::Vec<D> t) {
  using V = hn::Vec<D>;
  const V c = hn::LoadU(d, p);
  V dark[16], bright[16];
  for (int i = 0; i < 16; i += 4) {
    const V q = hn::LoadU(d, p + ofs[i]);
    dark[i] = hn::SaturatedSub(c, q);
    bright[i] = hn::SaturatedSub(q, c);
  }
  // Any arc of 9 holds two neighbouring quarter points (0, 4, 8, 12): a cheap necessary test.
  V quick = hn::Zero(d);
  for (int i = 0; i < 16; i += 4) {
    quick = hn::Max(quick, hn::Min(dark[i], dark[(i + 4) & 15]));
    quick = hn::Max(quick, hn::Min(bright[i], bright[(i + 4) & 15]));
  }
  if (hn::AllFalse(d, hn::Gt(quick, t))) return hn::Zero(d);
  for (int i = 0; i < 16; ++i) {
    if ((i & 3) == 0) continue;
    const V q = hn::LoadU(d, p + ofs[i]);
    dark[i] = hn::SaturatedSub(c, q);
    bright[i] = hn::SaturatedSub(q, c);
  }
  const V m = hn::Max(MaxArcMin(dark), MaxArcMin(bright));
  return hn::IfThenElseZero(hn::Gt(m, t), hn::Sub(m, hn::Set(d, 1)));
}

// Scores of row `row` into out[3 .. cols-4]; the last vector is moved back to end at cols-4 (overlap is harmless).
template <class D>
HWY_INLINE void ScoreRow(D d, const uint8_t* row, const ptrdiff_t* ofs, int cols, int threshold, uint8_t* out) {
  const int n = static_cast<int>(hn::Lanes(d));
  const int last = cols - 3 - n;  // first column of the vector ending at cols-4
  if (last < 3) {
    for (int x = 3; x <= cols - 4; ++x) out[x] = ScalarScore(row + x, ofs, threshold);
    return;
  }
  const auto t = hn::Set(d, static_cast<uint8_t>(threshold));
  for (int x = 3;; x += n) {
    x = std::min(x, last);
    hn::StoreU(VectorScore(d, row + x, ofs, t), d, out + x);
    if (x == last) break;
  }
}

// Keeps the corners of row y whose score beats all 8 neighbours'. Score rows are zero outside [3, cols-4] and
// readable on [0, cols + lanes).
template <class D>
HWY_INLINE void SuppressRow(D d, const uint8_t* above, const uint8_t* cur, const uint8_t* below, int y, int cols,
                            std::vector<cv::KeyPoint>* out) {
  const int n = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d);
  uint8_t bits[(HWY_MAX_BYTES + 7) / 8 + 8];
  for (int x = 3; x <= cols - 4; x += n) {
    const auto s = hn::LoadU(d, cur + x);
    auto keep = hn::Gt(s, zero);
    if (hn::AllFalse(d, keep)) continue;
    keep = hn::And(keep, hn::And(hn::Gt(s, hn::LoadU(d, cur + x - 1)), hn::Gt(s, hn::LoadU(d, cur + x + 1))));
    keep = hn::And(keep, hn::And(hn::Gt(s, hn::LoadU(d, above + x - 1)), hn::Gt(s, hn::LoadU(d, above + x))));
    keep = hn::And(keep, hn::And(hn::Gt(s, hn::LoadU(d, above + x + 1)), hn::Gt(s, hn::LoadU(d, below + x - 1))));
    keep = hn::And(keep, hn::And(hn::Gt(s, hn::LoadU(d, below + x)), hn::Gt(s, hn::LoadU(d, below + x + 1))));
    // Capped: Highway 1.0.3's FirstN compares against the count as a lane value (wraps past 127 for u8).
    keep = hn::And(keep, hn::FirstN(d, static_cast<size_t>(std::min(n, cols - 3 - x))));
    if (hn::AllFalse(d, keep)) continue;
    const size_t nbytes = hn::StoreMaskBits(d, keep, bits);
    for (size_t b = 0; b < nbytes; ++b) {
      for (unsigned m = bits[b]; m != 0; m &= m - 1) {
        const int xi = x + static_cast<int>(b * 8) + __builtin_ctz(m);
        out->emplace_back(static_cast<float>(xi), static_cast<float>(y), 7.f, -1.f, static_cast<float>(cur[xi]));
      }
    }
  }
}

void DetectFastCornersImpl(const uint8_t* image, size_t step, int rows, int cols, int threshold,
                           std::vector<cv::KeyPoint>* out) {
  const hn::ScalableTag<uint8_t> d;
  const int n = static_cast<int>(hn::Lanes(d));
  ptrdiff_t ofs[16];
  for (int i = 0; i < 16; ++i)
    ofs[i] = static_cast<ptrdiff_t>(kCircle[i][1]) * static_cast<ptrdiff_t>(step) + kCircle[i][0];
  // Three rolling score rows (previous, current, next), zero-padded so unaligned neighbour loads stay inside.
  const size_t stride = static_cast<size_t>(cols + 2 * n + 8);
  std::vector<uint8_t> buffer(3 * stride, 0);
  auto slot = [&](int y) { return buffer.data() + static_cast<size_t>(y % 3) * stride; };
  for (int y = 3; y <= rows - 3; ++y) {
    uint8_t* cur = slot(y);
    if (y <= rows - 4) {
      ScoreRow(d, image + static_cast<size_t>(y) * step, ofs, cols, threshold, cur);
    } else {
      std::memset(cur, 0, stride);  // the row below the last candidate row
    }
    if (y >= 4) SuppressRow(d, slot(y - 2), slot(y - 1), cur, y - 1, cols, out);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace rs
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace rs {

HWY_EXPORT(DetectFastCornersImpl);

void DetectFastCorners(const cv::Mat& gray8u, int threshold, std::vector<cv::KeyPoint>* out) {
  CV_Assert(gray8u.type() == CV_8UC1);
  // OpenCV 4.6 does not clamp consistently (its SIMD pass wraps the threshold to u8, its scalar pass does not):
  // outside [0, 255] there is no one answer to reproduce.
  if (threshold < 0 || threshold > 255)
    throw std::invalid_argument("DetectFastCorners: threshold " + std::to_string(threshold) + " outside [0, 255]");
  out->clear();
  if (gray8u.rows < 7 || gray8u.cols < 7) return;
  HWY_DYNAMIC_DISPATCH(DetectFastCornersImpl)(gray8u.data, gray8u.step, gray8u.rows, gray8u.cols, threshold, out);
}

}  // namespace rs
#endif  // HWY_ONCE
