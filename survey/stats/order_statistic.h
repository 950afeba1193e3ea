#pragma once
// Order statistics of samples as the damage stage takes them. Each selects the element
// std::nth_element would put at the rank (results stay those of the ad-hoc code they replaced);
// the rank conventions are named because callers differ: the lower median v[n/2], a quantile's
// rank rounded down or to nearest.
//
// KthSmallestNonNegative: for non-negative doubles the order of their bit patterns as unsigned
// integers is the order of the values, so two histogram passes on the top bits narrow the search
// to a few values, which nth_element finishes. About three times faster than nth_element's
// partitioning on the road fit's 25 000 residuals (its IRLS median ran every pass on the serial
// path); the same value.

#include <algorithm>
#include <array>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace rs {

/// The value std::nth_element puts at position k of `v` (k < v.size()); `v` is reordered.
template <class T>
T KthSmallestInPlace(std::vector<T>& v, size_t k) {
  assert(k < v.size());
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// The lower median v[n/2] (the upper of the two middle values for even n); `v` is reordered
/// and must not be empty.
template <class T>
T LowerMedianInPlace(std::vector<T>& v) {
  return KthSmallestInPlace(v, v.size() / 2);
}

/// Rank of the q-quantile (q in [0, 1]) of n > 0 values, rounded down: ⌊q·(n − 1)⌋.
inline size_t QuantileRankDown(double q, size_t n) { return static_cast<size_t>(q * double(n - 1)); }

/// Rank of the q-quantile (q in [0, 1]) of n > 0 values, rounded to nearest (halves up):
/// ⌊q·(n − 1) + 0.5⌋, at most n − 1. q = 0.5 gives n/2, the lower median's rank.
inline size_t QuantileRankNearest(double q, size_t n) {
  return std::min(n - 1, static_cast<size_t>(q * double(n - 1) + 0.5));
}

/// The k-th smallest (k from 0) of a sample of small non-negative integers given as counts per
/// value (`counts[x]` samples equal x, x < bins): the first value whose cumulative count exceeds
/// k. k must be less than the total count.
template <class Count>
int KthSmallestOfCounts(const Count* counts, int bins, size_t k) {
  size_t below = 0;
  int x = 0;
  while (x + 1 < bins && below + static_cast<size_t>(counts[x]) <= k) below += static_cast<size_t>(counts[x++]);
  return x;
}

/// The value std::nth_element would put at position k of `v` (k < v.size()). Every value must be
/// ≥ +0 and not NaN for the radix path; otherwise (a sign bit or NaN seen) nth_element on `v`
/// itself. `v` may be reordered.
inline double KthSmallestNonNegative(std::vector<double>& v, size_t k) {
  auto key = [](double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
  };
  constexpr std::uint64_t kNaNOrNegative = 0x7ff0000000000001ull;  // keys ≥ this: NaN or sign bit set
  std::array<std::uint32_t, 4096> hist{};
  // Pass 1: bits 63..52 (sign and exponent).
  for (double x : v) {
    const std::uint64_t b = key(x);
    if (b >= kNaNOrNegative) return KthSmallestInPlace(v, k);
    ++hist[b >> 52];
  }
  auto bucket = [&](size_t& rank) {
    std::uint32_t i = 0;
    while (rank >= hist[i]) rank -= hist[i++];
    return i;
  };
  size_t rank = k;
  const std::uint64_t top = bucket(rank);
  // Pass 2: bits 51..40 of the values in that bucket.
  hist.fill(0);
  for (double x : v)
    if (const std::uint64_t b = key(x); (b >> 52) == top) ++hist[(b >> 40) & 0xfff];
  const std::uint64_t prefix = (top << 12) | bucket(rank);
  // Pass 3: the values sharing those 24 bits, ranked among themselves.
  std::vector<double> rest;
  for (double x : v)
    if ((key(x) >> 40) == prefix) rest.push_back(x);
  return KthSmallestInPlace(rest, rank);
}

}  // namespace rs
