#include "survey/stats/robust_stats.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace rs {
namespace {

// 1.4826 · lower median |r|, exactly as written out before (floats widened to double first); the
// doubles' radix path returns the same bits as nth_element, also with -0 and exact ties.
TEST(RobustStats, RobustSigmaOfAbs) {
  std::vector<float> f{0.3f, 0.1f, 0.2f};
  EXPECT_EQ(RobustSigmaOfAbs(f), 1.4826 * double(0.2f));
  std::vector<double> d{4, 1, 3, 2};
  EXPECT_EQ(RobustSigmaOfAbs(d), 1.4826 * 3);
  std::vector<double> z{0.0, -0.0, 0.0};
  EXPECT_EQ(RobustSigmaOfAbs(z), 0.0);
  std::mt19937 rng(7);
  std::exponential_distribution<double> e(50.0);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> a(1 + rng() % 30000);
    for (double& x : a) x = trial % 2 ? e(rng) : std::round(e(rng) * 1000) / 1000;
    std::vector<double> ref = a;
    std::nth_element(ref.begin(), ref.begin() + static_cast<std::ptrdiff_t>(ref.size() / 2), ref.end());
    EXPECT_EQ(RobustSigmaOfAbs(a), 1.4826 * ref[ref.size() / 2]);
  }
}

// The one-sided and two-sided spreads: exact arithmetic of the replaced expressions, NaN kept
// where the callers let it through.
TEST(RobustStats, OneAndTwoSidedSigma) {
  EXPECT_EQ(SigmaOfMedianAbs(2.0), 1.4826 * 2.0);
  EXPECT_EQ(SigmaOfOneSidedMedian(0.6745), 1.0);
  EXPECT_EQ(SigmaOfOneSidedMedian(double(0.3f)), double(0.3f) / 0.6745);
  EXPECT_EQ(TwoSidedSigma(3.0, 1.0, 2.0), 2.0);  // capped
  EXPECT_EQ(TwoSidedSigma(1.5, 1.0, 2.0), 1.5);  // sides agree within the factor: up unchanged
  EXPECT_EQ(TwoSidedSigma(0.7f, 0.3f, 2.0f), std::min(0.7f, 0.3f * 2.0f));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isnan(TwoSidedSigma(nan, 1.0, 2.0)));
  EXPECT_EQ(TwoSidedSigma(1.0, nan, 2.0), 1.0);  // std::min(up, NaN) keeps up
}

}  // namespace
}  // namespace rs
