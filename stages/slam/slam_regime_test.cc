#include "stages/slam/slam_regime.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

// Features with the given stereo depths (and as many without one, which must not count).
StereoFeatures WithDepths(const std::vector<float>& depths) {
  StereoFeatures f;
  for (float d : depths) {
    f.keypoints.emplace_back(10.f, 10.f, 7.f);
    f.depth_m.push_back(d);
    f.keypoints.emplace_back(20.f, 20.f, 7.f);
    f.depth_m.push_back(-1);
  }
  return f;
}

// Depths spread evenly (linearly) over [near, far].
std::vector<float> Spread(float near, float far, int n) {
  std::vector<float> d;
  for (int i = 0; i < n; ++i) d.push_back(near + (far - near) * static_cast<float>(i) / static_cast<float>(n - 1));
  return d;
}

TEST(SlamRegime, FlatGroundFromAboveIsNadir) {
  const RegimeChoice c = ChooseRegime(SlamOptions(), WithDepths(Spread(5.5f, 6.5f, 200)));
  EXPECT_EQ(c.regime, SlamRegime::kNadir);
  EXPECT_TRUE(c.automatic);
  EXPECT_EQ(c.stereo_points, 200);
  // Percentiles of an even spread: 5.5 + 0.1 / 0.9 of the range, to one sample step.
  EXPECT_NEAR(c.depth_p10_m, 5.6, 0.01);
  EXPECT_NEAR(c.depth_p90_m, 6.4, 0.01);
  EXPECT_NEAR(c.depth_spread, 6.4 / 5.6, 0.005);
  EXPECT_NE(c.reason.find("nadir"), std::string::npos) << c.reason;
}

TEST(SlamRegime, RoadToHorizonIsForward) {
  const RegimeChoice c = ChooseRegime(SlamOptions(), WithDepths(Spread(3.f, 63.f, 301)));
  EXPECT_EQ(c.regime, SlamRegime::kForward);
  EXPECT_NEAR(c.depth_p10_m, 9.0, 0.01);
  EXPECT_NEAR(c.depth_p90_m, 57.0, 0.01);
  EXPECT_NE(c.reason.find("forward"), std::string::npos) << c.reason;
}

TEST(SlamRegime, TooFewStereoPointsKeepTheOptionsAsGiven) {
  const RegimeChoice c = ChooseRegime(SlamOptions(), WithDepths(Spread(3.f, 63.f, kRegimeMinStereoPoints - 1)));
  EXPECT_EQ(c.regime, SlamRegime::kNadir);
  EXPECT_EQ(c.depth_spread, 0);
  EXPECT_NE(c.reason.find("too few"), std::string::npos) << c.reason;
}

TEST(SlamRegime, ExplicitRegimeWins) {
  SlamOptions o;
  o.regime = SlamRegime::kForward;
  const RegimeChoice c = ChooseRegime(o, WithDepths(Spread(5.5f, 6.5f, 200)));
  EXPECT_EQ(c.regime, SlamRegime::kForward);
  EXPECT_FALSE(c.automatic);
}

TEST(SlamRegime, ForwardOptions) {
  SlamOptions given;
  const SlamOptions f = OptionsForRegime(given, SlamRegime::kForward);
  EXPECT_EQ(f.features, 2000);
  EXPECT_EQ(f.triangulation_neighbours, 5);
  EXPECT_EQ(f.local_ba_iterations, 5);
  EXPECT_TRUE(f.local_ba_fixed_size);
  EXPECT_EQ(f.keyframe_max_gap, 5);
  // A user's larger feature count or own triangulation setting is kept.
  given.features = 3000;
  given.triangulation_neighbours = 10;
  EXPECT_EQ(OptionsForRegime(given, SlamRegime::kForward).features, 3000);
  EXPECT_EQ(OptionsForRegime(given, SlamRegime::kForward).triangulation_neighbours, 10);
  const SlamOptions n = OptionsForRegime(given, SlamRegime::kNadir);
  EXPECT_EQ(n.features, 3000);
  EXPECT_EQ(n.keyframe_max_gap, given.keyframe_max_gap);
  EXPECT_FALSE(n.local_ba_fixed_size);
}

}  // namespace
}  // namespace rs
