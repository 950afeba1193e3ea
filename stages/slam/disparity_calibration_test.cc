#include "stages/slam/disparity_calibration.h"

#include <random>

#include <gtest/gtest.h>

namespace rs {
namespace {

// Synthetic keyframe pairs of a forward-moving KITTI-like rig (bf = 380 px m): points at 4-60 m,
// disparities measured short by `offset` plus 0.15 px noise and 2 % wrong matches.
std::vector<DisparityPairSample> ForwardPairs(double offset, double forward_m, double depth_min_m, double depth_max_m,
                                              int* pairs) {
  const double bf = 380;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> depth(depth_min_m, depth_max_m), image(-0.8, 0.8), yaw(-0.02, 0.02);
  std::normal_distribution<double> noise(0, 0.15);
  std::uniform_real_distribution<double> wrong(-8, 8);
  std::vector<DisparityPairSample> out;
  *pairs = 8;
  for (int p = 0; p < *pairs; ++p) {
    const double w = yaw(rng), c = std::cos(w), s = std::sin(w);
    for (int k = 0; k < 400; ++k) {
      const double zi = depth(rng), x = image(rng) * zi;
      // p_j = R_y(w) p_i + (0, 0, -forward): the point comes nearer (only z matters here).
      const double zj = -s * x + c * zi - forward_m;
      if (zj < 2) continue;
      DisparityPairSample d;
      d.pair = p;
      d.a = -s * (x / zi) + c;
      d.d_i = bf / zi - offset + noise(rng);
      d.d_j = bf / zj - offset + noise(rng);
      if (k % 50 == 0) d.d_j += wrong(rng);
      out.push_back(d);
    }
  }
  return out;
}

TEST(DisparityCalibration, RecoversOffsetOfForwardMotion) {
  for (double truth : {0.25, 0.0, -0.3}) {
    int pairs = 0;
    const auto samples = ForwardPairs(truth, 2.4, 4, 60, &pairs);
    const DisparityOffsetEstimate e = EstimateDisparityOffset(samples, pairs, 380);
    EXPECT_TRUE(e.valid) << truth;
    EXPECT_NEAR(e.offset_px, truth, 0.06) << "sigma " << e.sigma_px;  // ~2 sigma
    EXPECT_LT(e.sigma_px, 0.035);
    EXPECT_GT(e.samples, 2800);
  }
}

// Sideways motion over points at one depth (a nadir camera over flat road): the apparent depth change
// does not depend on the offset, which must come out as not estimable rather than as a number.
TEST(DisparityCalibration, SidewaysMotionIsNotObservable) {
  int pairs = 0;
  const auto samples = ForwardPairs(0.0, 0.0, 5.8, 6.2, &pairs);
  const DisparityOffsetEstimate e = EstimateDisparityOffset(samples, pairs, 380);
  EXPECT_FALSE(e.valid) << "offset " << e.offset_px << " sigma " << e.sigma_px;
}

TEST(DisparityCalibration, TooFewSamples) {
  int pairs = 0;
  auto samples = ForwardPairs(0.25, 2.4, 4, 60, &pairs);
  samples.resize(200);
  EXPECT_FALSE(EstimateDisparityOffset(samples, pairs, 380).valid);
}

}  // namespace
}  // namespace rs
