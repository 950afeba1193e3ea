#include "eval/damage/sim_damage_survey.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

PotholeObservation Obs(const char* frame, int id, bool detected, bool floor_visible, double sigma_m, double depth_m) {
  PotholeObservation o;
  o.frame = frame;
  o.truth_id = id;
  o.detected = detected;
  o.floor_visible = floor_visible;
  o.sigma_depth_m = sigma_m;
  o.truth_max_depth_m = 0.050;
  o.truth_area_m2 = 0.20;
  o.truth_volume_m3 = 0.004;
  o.truth_severity = "M";
  o.range_m = 1000 * sigma_m;  // any monotone stand-in: the pick must not read it
  if (detected) {
    o.max_depth_m = depth_m;
    o.area_m2 = 0.22;
    o.volume_m3 = 0.0036;
    o.astm = SeverityLevel::kMedium;
  }
  return o;
}

// A seen floor beats a smaller σ_Z behind a hidden rim; a missed frame never counts; a pothole
// matched nowhere lowers the recall.
TEST(SimDamageSurvey, KeepsTheSeenFloorThenTheLeastSigma) {
  SimDamageEvaluation e;
  e.observations = {Obs("000001", 7, false, true, 0.005, 0), Obs("000002", 7, true, false, 0.008, 0.030),
                    Obs("000003", 7, true, true, 0.020, 0.056), Obs("000004", 7, true, true, 0.012, 0.047),
                    Obs("000002", 9, false, true, 0.010, 0)};
  const SimDamageSurveyFigures f = SummarisePerPothole(e);
  EXPECT_EQ(f.potholes, 2);
  EXPECT_EQ(f.detected, 1);
  EXPECT_DOUBLE_EQ(f.recall, 0.5);
  ASSERT_EQ(f.kept.size(), 1u);
  EXPECT_EQ(f.kept[0].frame, "000004");
  EXPECT_EQ(f.floor_seen, 1);
  EXPECT_NEAR(f.seen_depth_error_mm.mean, -3.0, 1e-9);
  EXPECT_NEAR(f.area_error_pct.mean, 10.0, 1e-9);
  EXPECT_NEAR(f.volume_error_pct.mean, -10.0, 1e-9);
  EXPECT_DOUBLE_EQ(f.severity_agreement, 1.0);
  EXPECT_NE(f.Report().find("recall 0.500 (1/2)"), std::string::npos) << f.Report();
}

TEST(SimDamageSurvey, HiddenFloorsAreKeptButNotScoredForDepth) {
  SimDamageEvaluation e;
  e.observations = {Obs("000001", 3, true, false, 0.010, 0.020), Obs("000002", 3, true, false, 0.006, 0.025)};
  const SimDamageSurveyFigures f = SummarisePerPothole(e);
  ASSERT_EQ(f.kept.size(), 1u);
  EXPECT_EQ(f.kept[0].frame, "000002");
  EXPECT_EQ(f.floor_seen, 0);
  EXPECT_EQ(f.seen_depth_error_mm.n, 0);
  EXPECT_EQ(f.area_error_pct.n, 1);
}

TEST(SimDamageSurvey, EmptyEvaluation) {
  const SimDamageSurveyFigures f = SummarisePerPothole(SimDamageEvaluation{});
  EXPECT_EQ(f.potholes, 0);
  EXPECT_EQ(f.recall, 0.0);
  EXPECT_TRUE(f.kept.empty());
}

}  // namespace
}  // namespace rs
