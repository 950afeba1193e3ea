#include "survey/stats/order_statistic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace rs {
namespace {

// Exact order statistics of small samples, odd and even sizes.
TEST(OrderStatistic, KthSmallestAndLowerMedian) {
  std::vector<int> odd{5, 1, 4, 2, 3};
  EXPECT_EQ(LowerMedianInPlace(odd), 3);
  EXPECT_EQ(KthSmallestInPlace(odd, 0), 1);
  EXPECT_EQ(KthSmallestInPlace(odd, 4), 5);
  std::vector<float> even{4.f, 1.f, 3.f, 2.f};
  EXPECT_EQ(LowerMedianInPlace(even), 3.f);  // v[n/2]: the upper of the middle pair, not their mean
  std::vector<double> one{-7.5};
  EXPECT_EQ(LowerMedianInPlace(one), -7.5);
  std::vector<double> ties{2, 2, 1, 2};
  EXPECT_EQ(LowerMedianInPlace(ties), 2);
}

// The two rank conventions on n values, including the edges q = 0, q = 1 and n = 1, and the
// identity the callers rely on: the nearest rank of q = 0.5 is the lower median's n/2.
TEST(OrderStatistic, QuantileRanks) {
  EXPECT_EQ(QuantileRankDown(0.98, 101), 98u);
  EXPECT_EQ(QuantileRankDown(0.98, 100), 97u);  // 97.02
  EXPECT_EQ(QuantileRankNearest(0.98, 100), 97u);
  EXPECT_EQ(QuantileRankDown(0.5, 4), 1u);         // 1.5 down
  EXPECT_EQ(QuantileRankNearest(0.5, 4), 2u);      // 1.5 up
  EXPECT_EQ(QuantileRankDown(0.999, 1000), 998u);  // 998.001
  EXPECT_EQ(QuantileRankNearest(0.999, 1000), 998u);
  EXPECT_EQ(QuantileRankDown(0.9995, 1000), 998u);  // 998.5005: the conventions differ
  EXPECT_EQ(QuantileRankNearest(0.9995, 1000), 999u);
  for (size_t n : {1u, 2u, 7u}) {
    EXPECT_EQ(QuantileRankDown(0.0, n), 0u);
    EXPECT_EQ(QuantileRankNearest(0.0, n), 0u);
    EXPECT_EQ(QuantileRankDown(1.0, n), n - 1);
    EXPECT_EQ(QuantileRankNearest(1.0, n), n - 1);
  }
  EXPECT_EQ(QuantileRankNearest(1.5, 10), 9u);  // clamped to the last rank
  for (size_t n = 1; n <= 20000; ++n) ASSERT_EQ(QuantileRankNearest(0.5, n), n / 2) << n;
}

// The selections equal std::nth_element on random samples (the replaced code) for every rank
// convention, floats and doubles, with ties and signs.
TEST(OrderStatistic, EqualsNthElement) {
  std::mt19937 rng(11);
  std::normal_distribution<float> g(0.f, 3.f);
  for (int trial = 0; trial < 50; ++trial) {
    const size_t n = 1 + rng() % 2000;
    std::vector<float> a(n);
    for (float& x : a) x = std::round(g(rng) * 4.f) / 4.f;  // many ties
    for (double q : {0.01, 0.5, 0.98, 0.999}) {
      for (size_t k : {QuantileRankDown(q, n), QuantileRankNearest(q, n)}) {
        std::vector<float> ref = a, got = a;
        std::nth_element(ref.begin(), ref.begin() + static_cast<std::ptrdiff_t>(k), ref.end());
        EXPECT_EQ(KthSmallestInPlace(got, k), ref[k]) << "trial " << trial << " q " << q;
      }
    }
  }
}

// KthSmallestOfCounts is the k-th smallest of the sample the counts describe, at every k, also
// when the answer is the last bin; and the MAD taken on counts (RobustLevel in cracks.cc) is the
// lower median of the absolute deviations.
TEST(OrderStatistic, KthSmallestOfCounts) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<std::uint8_t> s(1 + rng() % 500);
    for (auto& x : s) x = static_cast<std::uint8_t>(trial == 0 ? 255 : (rng() % 40) * (rng() % 7));
    size_t counts[256] = {0};
    for (auto x : s) ++counts[x];
    std::vector<std::uint8_t> sorted = s;
    std::sort(sorted.begin(), sorted.end());
    for (size_t k = 0; k < s.size(); ++k) ASSERT_EQ(KthSmallestOfCounts(counts, 256, k), sorted[k]);
    const int m = KthSmallestOfCounts(counts, 256, s.size() / 2);
    int dev[256] = {0};
    std::vector<int> abs_dev;
    for (auto x : s) ++dev[std::abs(x - m)], abs_dev.push_back(std::abs(x - m));
    EXPECT_EQ(KthSmallestOfCounts(dev, 256, s.size() / 2), LowerMedianInPlace(abs_dev));
  }
  const int single[3] = {0, 1, 0};
  EXPECT_EQ(KthSmallestOfCounts(single, 3, 0), 1);
}

}  // namespace
}  // namespace rs
