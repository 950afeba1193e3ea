#include "stages/slam/slam_regime.h"

#include <cmath>

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

TEST(SlamRegime, FlatGroundWaitsForMotion) {
  const RegimeChoice c = ChooseRegimeFromDepths(SlamOptions(), WithDepths(Spread(5.5f, 6.5f, 200)));
  EXPECT_EQ(c.regime, SlamRegime::kNadir);  // the options as given until decided
  EXPECT_FALSE(c.decided);
  EXPECT_TRUE(c.automatic);
  EXPECT_NEAR(c.depth_p50_m, 6.0, 0.01);
  EXPECT_EQ(c.stereo_points, 200);
  // Percentiles of an even spread: 5.5 + 0.1 / 0.9 of the range, to one sample step.
  EXPECT_NEAR(c.depth_p10_m, 5.6, 0.01);
  EXPECT_NEAR(c.depth_p90_m, 6.4, 0.01);
  EXPECT_NEAR(c.depth_spread, 6.4 / 5.6, 0.005);
  EXPECT_NE(c.reason.find("nadir"), std::string::npos) << c.reason;
}

TEST(SlamRegime, RoadToHorizonIsForward) {
  const RegimeChoice c = ChooseRegimeFromDepths(SlamOptions(), WithDepths(Spread(3.f, 63.f, 301)));
  EXPECT_EQ(c.regime, SlamRegime::kForward);
  EXPECT_TRUE(c.decided);
  EXPECT_NEAR(c.depth_p10_m, 9.0, 0.01);
  EXPECT_NEAR(c.depth_p90_m, 57.0, 0.01);
  EXPECT_NE(c.reason.find("forward"), std::string::npos) << c.reason;
}

TEST(SlamRegime, TooFewStereoPointsAreNotJudged) {
  RegimeChoice c = ChooseRegimeFromDepths(SlamOptions(), WithDepths(Spread(3.f, 63.f, kRegimeMinStereoPoints - 1)));
  EXPECT_FALSE(c.decided);
  EXPECT_EQ(c.depth_spread, 0);
  EXPECT_NE(c.reason.find("stereo points"), std::string::npos) << c.reason;
  // Without a median depth the motion cannot be judged either: the options as given at the last frame.
  EXPECT_FALSE(DecideRegimeFromMotion(&c, {0, 0, 5}, 1));
  EXPECT_TRUE(DecideRegimeFromMotion(&c, {0, 0, 5}, kRegimeLastFrame));
  EXPECT_EQ(c.regime, SlamRegime::kNadir);
}

// A shallow view (the simulated car sees the road 2.7-4.6 m away): forward when the camera moves along
// its optical axis, nadir when it moves across it; the motion is judged once it reaches 5 % of the
// median depth (6 m: 0.3 m).
TEST(SlamRegime, MotionDecidesAShallowView) {
  const RegimeChoice shallow = ChooseRegimeFromDepths(SlamOptions(), WithDepths(Spread(5.5f, 6.5f, 200)));
  RegimeChoice along = shallow;
  EXPECT_FALSE(DecideRegimeFromMotion(&along, {0.01, 0.05, 0.25}, 1));  // 0.255 m: not yet
  EXPECT_TRUE(DecideRegimeFromMotion(&along, {0.02, 0.15, 0.52}, 2));
  EXPECT_EQ(along.regime, SlamRegime::kForward);
  EXPECT_NEAR(along.forward_share, 0.52 / std::sqrt(0.02 * 0.02 + 0.15 * 0.15 + 0.52 * 0.52), 1e-9);
  EXPECT_NE(along.reason.find("forward"), std::string::npos) << along.reason;
  RegimeChoice across = shallow;
  EXPECT_TRUE(DecideRegimeFromMotion(&across, {0.33, 0.02, 0.01}, 1));
  EXPECT_EQ(across.regime, SlamRegime::kNadir);
  EXPECT_LT(across.forward_share, 0.05);
  RegimeChoice still = shallow;  // a static start: the options as given at the last frame
  EXPECT_FALSE(DecideRegimeFromMotion(&still, {0, 0, 0.01}, kRegimeLastFrame - 1));
  EXPECT_TRUE(DecideRegimeFromMotion(&still, {0, 0, 0.01}, kRegimeLastFrame));
  EXPECT_EQ(still.regime, SlamRegime::kNadir);
}

TEST(SlamRegime, ExplicitRegimeWins) {
  SlamOptions o;
  o.regime = SlamRegime::kForward;
  const RegimeChoice c = ChooseRegimeFromDepths(o, WithDepths(Spread(5.5f, 6.5f, 200)));
  EXPECT_EQ(c.regime, SlamRegime::kForward);
  EXPECT_TRUE(c.decided);
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
