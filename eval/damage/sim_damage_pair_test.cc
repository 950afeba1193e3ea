#include "eval/damage/sim_damage_pair.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

PotholeObservation Obs(const char* frame, int id, bool detected, double area_m2, double volume_m3, double depth_m,
                       bool floor_visible = true) {
  PotholeObservation o;
  o.frame = frame;
  o.truth_id = id;
  o.detected = detected;
  o.truth_max_depth_m = 0.050, o.truth_area_m2 = 0.20, o.truth_volume_m3 = 0.004;
  o.floor_visible = floor_visible;
  if (detected) o.area_m2 = area_m2, o.volume_m3 = volume_m3, o.max_depth_m = depth_m;
  return o;
}

// Pairs by frame and truth id; the change is in |error|, so an error that flips sign at the same
// size is no change; unpaired and one-sided detections are counted apart.
TEST(SimDamagePair, ComparesTheSameObservationsOnly) {
  SimDamageEvaluation with, without;
  with.observations = {Obs("000001", 4, true, 0.22, 0.0036, 0.047),  // +10 %, -10 %, -3 mm
                       Obs("000002", 4, true, 0.18, 0.0040, 0.052),  // -10 %, 0 %, +2 mm
                       Obs("000002", 5, true, 0.20, 0.0040, 0.050),  // detected only with
                       Obs("000003", 6, false, 0, 0, 0)};            // missed in both
  with.road_median_abs_mm = 0.50;
  without.observations = {Obs("000001", 4, true, 0.21, 0.0036, 0.049),  // +5 %, -10 %, -1 mm
                          Obs("000002", 4, true, 0.22, 0.0040, 0.052),  // +10 %, 0 %, +2 mm
                          Obs("000002", 5, false, 0, 0, 0), Obs("000003", 6, false, 0, 0, 0),
                          Obs("000004", 9, true, 0.20, 0.0040, 0.050)};  // hidden by an obstacle in `with`
  without.road_median_abs_mm = 0.45;
  const PairedObstacleFigures f = CompareObstacleRenders(with, without);
  EXPECT_EQ(f.paired, 2);
  EXPECT_EQ(f.only_with, 1);
  EXPECT_EQ(f.only_without, 0);
  EXPECT_EQ(f.scored_only_without, 1);
  EXPECT_NEAR(f.worst_area_pp, 5.0, 1e-9);  // 10 - 5; the other 10 - 10 = 0
  EXPECT_NEAR(f.area_pp.mean, 2.5, 1e-9);
  EXPECT_NEAR(f.worst_volume_pp, 0.0, 1e-9);
  EXPECT_NEAR(f.worst_depth_mm, 2.0, 1e-9);
  EXPECT_EQ(f.depth_mm.n, 2);
  EXPECT_NEAR(f.road_delta_mm, 0.05, 1e-12);
  EXPECT_NE(f.Report().find("2 observations paired"), std::string::npos) << f.Report();
}

// Hidden floors give no depth pair; a better figure with the obstacles is no worsening.
TEST(SimDamagePair, HiddenFloorsAndImprovements) {
  SimDamageEvaluation with, without;
  with.observations = {Obs("000001", 1, true, 0.20, 0.0040, 0.030, false)};
  without.observations = {Obs("000001", 1, true, 0.24, 0.0030, 0.030, false)};
  const PairedObstacleFigures f = CompareObstacleRenders(with, without);
  EXPECT_EQ(f.paired, 1);
  EXPECT_EQ(f.depth_mm.n, 0);
  EXPECT_DOUBLE_EQ(f.worst_area_pp, 0.0);
  EXPECT_DOUBLE_EQ(f.worst_volume_pp, 0.0);
  EXPECT_NEAR(f.area_pp.mean, -20.0, 1e-9);
}

}  // namespace
}  // namespace rs
