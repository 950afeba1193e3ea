#pragma once
// Robust spreads (σ) of samples as the damage stage takes them: from a median absolute
// deviation, from a one-sided median deviation, and the two-sided cap of the road's noise.
// The order statistics they rest on are in order_statistic.h.

#include <algorithm>
#include <cassert>
#include <type_traits>
#include <vector>

#include "survey/stats/order_statistic.h"

namespace rs {

/// Normal σ per unit median absolute deviation: 1 / Φ⁻¹(0.75), rounded as the stage uses it.
inline constexpr double kSigmaPerMad = 1.4826;
/// A normal σ's median absolute deviation, Φ⁻¹(0.75), rounded as the stage uses it.
inline constexpr double kMadPerSigma = 0.6745;

/// Robust σ from a median absolute deviation (or the median |r| of zero-centred residuals):
/// 1.4826 · it.
inline double SigmaOfMedianAbs(double median_abs) { return kSigmaPerMad * median_abs; }

/// Robust σ from the median of the deviations to one side of a normal sample's centre:
/// median / 0.6745 (damage fills one tail, so the other side measures the noise).
inline double SigmaOfOneSidedMedian(double median) { return median / kMadPerSigma; }

/// Robust σ of a zero-centred sample from its absolute values `abs_r` (not empty; reordered):
/// 1.4826 · their lower median. Doubles are selected by radix (KthSmallestNonNegative: the same
/// value, faster on the road fit's large samples).
template <class T>
double RobustSigmaOfAbs(std::vector<T>& abs_r) {
  assert(!abs_r.empty());
  if constexpr (std::is_same_v<T, double>)
    return SigmaOfMedianAbs(KthSmallestNonNegative(abs_r, abs_r.size() / 2));
  else
    return SigmaOfMedianAbs(static_cast<double>(LowerMedianInPlace(abs_r)));
}

/// The noise σ from the spreads above and below the road: `up`, capped at `max_asymmetry` times
/// `down`. Matching noise errs both ways alike, so a spread above much larger than the one below
/// is a rise of the road the model does not follow, not noise.
template <class T>
T TwoSidedSigma(T up, T down, T max_asymmetry) {
  return std::min(up, down * max_asymmetry);
}

}  // namespace rs
