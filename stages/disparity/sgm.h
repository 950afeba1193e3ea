#pragma once
// Semi-global matching core: census cost, path aggregation, winner-takes-all,
// sub-pixel refinement, uniqueness and left-right checks. Two implementations of
// one definition: ComputeSgm (vectorised, oneTBB-parallel) and ComputeSgmReference
// (plain loops). Tests require bit-identical outputs.

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace rs {

/// Sub-pixel refinement of the integer winner from the aggregated costs S(k-1), S(k), S(k+1).
enum class SubpixelMode {
  kNone,         ///< integer disparities
  kParabola,     ///< vertex of the parabola through the three costs
  kEquiangular,  ///< symmetric V (equal-angle line) fit, suits census costs
};

/// Parameters of one SGM run. Validated by ComputeSgm (std::invalid_argument).
struct SgmParams {
  int census_width = 9;    ///< census window width, odd, width*height <= 65
  int census_height = 7;   ///< census window height, odd
  int ad_weight = 0;       ///< weight of the truncated |IL - IR| term; 0 = census only
  int ad_truncation = 20;  ///< |IL - IR| truncation, grey levels; ad_weight*ad_truncation + bits <= 255
  int num_paths = 8;       ///< 4 (horizontal + vertical) or 8 (+ both diagonals)
  int p1 = 10;             ///< penalty for a disparity change of +-1 between path neighbours
  int p2 = 120;            ///< penalty for larger changes, 1 <= p1 < p2 <= 1900
  /// P2 shrinks at intensity edges: P2' = max(P1, P2 * g / (|I(p) - I(p-r)| + g)), g = p2_gradient_scale.
  bool adaptive_p2 = true;
  int p2_gradient_scale = 16;  ///< g above, grey levels, >= 1
  int min_disparity = 0;       ///< smallest disparity searched (may be negative), px
  int num_disparities = 64;    ///< count of integer disparities searched, >= 1
  /// Optional per-row extra offset, px: row v searches min_disparity + row_offset[v] + [0, num_disparities).
  /// Empty = zero. This is what lets SGM follow a road model over a small range.
  std::vector<int> row_offset;
  int uniqueness_ratio = 5;  ///< percent, 0..99: reject when S(k) * (100 - r) < S_best * 100 for some |k - best| > 1
  SubpixelMode subpixel = SubpixelMode::kEquiangular;
  int lr_max_diff = 1;  ///< left-right check tolerance in px; negative disables the check

  /// Throws std::invalid_argument naming the rule broken (image height needed for row_offset).
  void Check(int image_height) const;
  /// Largest matching cost: census bits + ad_weight * ad_truncation.
  int MaxCost() const;
};

/// Output of one SGM run on the left (reference) view.
struct SgmOutput {
  cv::Mat disparity;     ///< CV_32F, px, d = min_disparity + row_offset[v] + k + sub-pixel; 0 where invalid
  cv::Mat valid;         ///< CV_8U, 255 valid, 0 rejected (border, uniqueness or left-right)
  double census_ms = 0;  ///< wall time of the census set-up (padding both images)
  /// Census rows + matching cost, time summed over threads (both run inside the aggregation pass,
  /// row token by row token).
  double cost_ms = 0;
  /// Wall time of cost + path aggregation; with 4 paths it includes winner-takes-all, which is
  /// fused into the last path.
  double aggregation_ms = 0;
  double wta_ms = 0;  ///< wall time of the left-right check (+ winner-takes-all with 8 paths)
};

/// Optimised SGM on rectified 8-bit grey images of equal size (left = reference).
/// The volumes (W*H*Dp*2 bytes with 4 paths and the default-sized costs and P2, else W*H*Dp*3;
/// Dp = D padded to the vector width) are cached per calling thread and reused, so a long-lived
/// worker keeps its largest frame's volumes allocated.
SgmOutput ComputeSgm(const cv::Mat& left_gray8, const cv::Mat& right_gray8, const SgmParams& params);

/// Naive scalar SGM of exactly the same definition (slow; for tests).
SgmOutput ComputeSgmReference(const cv::Mat& left_gray8, const cv::Mat& right_gray8, const SgmParams& params);

/// Census transform: bit = I(q) < I(p) over the window (centre skipped), row-major window
/// order, first compared pixel in the most significant used bit; borders replicate.
/// Returns one code per pixel, row-major.
std::vector<uint64_t> CensusTransform(const cv::Mat& gray8, int window_width, int window_height);

/// Sub-pixel offset in [-0.5, 0.5] from three aggregated costs (shared definition).
inline float SubpixelOffset(int s_minus, int s_best, int s_plus, SubpixelMode mode) {
  const int num = s_minus - s_plus;
  int den = 0;
  if (mode == SubpixelMode::kParabola) den = 2 * (s_minus + s_plus - 2 * s_best);
  if (mode == SubpixelMode::kEquiangular) den = 2 * ((s_minus > s_plus ? s_minus : s_plus) - s_best);
  if (den <= 0) return 0.0f;
  return static_cast<float>(num) / static_cast<float>(den);
}

}  // namespace rs
