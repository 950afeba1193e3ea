// Loop closing on small rendered surveys: an out-and-back flight whose return leg (image turned by
// 180 degrees) must be recognised and closed, and a one-way flight over look-alike road (same
// markings, same asphalt statistics) whose priors are folded so that they propose the wrong places:
// no loop may be closed there. Also tracking loss: camera dropouts (blank frames) bridged by
// prediction, and a new map segment merged by the return leg's loops.
#include "stages/slam/loop_closing.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "formats/stereo/image_io.h"
#include "formats/stereo/stereo_source.h"
#include "formats/trajectory/trajectory_file.h"
#include "sim/simulate.h"
#include "stages/slam/loop_verification.h"
#include "eval/trajectory/slam_datasets.h"
#include "stages/slam/stereo_slam.h"
#include "eval/trajectory/trajectory_metrics.h"
#include "tests/support/temp_dirs.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

// Renders `o` once per test program run into a temporary folder named after `name`.
fs::path Rendered(const std::string& name, const SimulationOptions& o) {
  const fs::path dir = fs::temp_directory_path() / ("rs_loop_test_" + name + "_" + std::to_string(::getpid()));
  if (!fs::exists(dir / "truth" / "trajectory.tum")) {
    test::RemoveAtExit(dir);
    Simulate(o, dir);
  }
  return dir;
}

// Quarter-size images (640 x 360, same 6 mm ground pixels, so a 3.8 x 2.2 m footprint).
SimulationOptions SmallRig(SimulationOptions o) {
  o.image_width = 640;
  o.image_height = 360;
  o.seed = 3;
  return o;
}

// Out and back: 10 m out, a 4 s turn on the spot, 9.5 m back (80 frames at 10 Hz).
SimulationOptions SmallLoop() {
  SimulationOptions o = SmallRig(PresetOptions("loop"));
  o.num_frames = 80;
  o.road_length_m = 40;  // turn at 25 m, start at 15 m
  return o;
}

SlamOptions SmallSlam() {
  SlamOptions s;
  s.features = 600;
  s.loop_min_gap_keyframes = 5;
  s.loop_min_inliers = 40;
  return s;
}

// Truth camera centre of each keyframe (keyframe times are frame times).
Eigen::Vector3d TruthCentre(const Trajectory& truth, int64_t t_ns) {
  for (const StampedPose& p : truth.poses)
    if (std::llabs(p.t_ns - t_ns) < 1'000'000) return p.T_world_frame.translation();
  ADD_FAILURE() << "no truth pose at " << t_ns;
  return Eigen::Vector3d::Zero();
}

TEST(LoopClosing, SmallOutAndBackLoopIsClosed) {
  const fs::path dir = Rendered("loop", SmallLoop());
  const SlamRunReport r = RunSimulated(dir, SmallSlam(), /*use_priors=*/true, /*prior_noise_m=*/1.0);
  const Trajectory truth = ReadTrajectory(dir / "truth" / "trajectory.tum", TrajectoryFormat::kTum);
  std::printf("%s\n", r.Summary("small loop").c_str());
  EXPECT_EQ(r.result.stats.frames, 80);
  EXPECT_EQ(r.result.stats.prior_only, 0);
  ASSERT_GE(r.result.stats.loops_closed, 1) << r.Summary("small loop");
  // Every closed loop links keyframes that truly see the same road: their camera centres are closer
  // than the footprint's along-track extent (2.2 m), i.e. the images overlap.
  for (const LoopClosure& l : r.result.loops) {
    const Keyframe& a = r.result.map.keyframes[l.keyframe];
    const Keyframe& b = r.result.map.keyframes[l.loop_keyframe];
    const double d = (TruthCentre(truth, a.t_ns) - TruthCentre(truth, b.t_ns)).norm();
    EXPECT_LT(d, 2.0) << "false loop kf " << l.keyframe << " -> " << l.loop_keyframe;
  }
  // The full `loop` preset is held to ATE RMSE <= 0.2 % of the path (421 m; measured 0.195 %,
  // docs/stages/slam.md). This 20 m loop on a narrow 640 x 360 field of view drifts more in rotation
  // (front end, not loop closing): measured 0.154 m = 0.74 %; the bound guards against regressions.
  EXPECT_LE(r.ate.translation_m.rmse, 0.01 * r.path_length_m) << r.Summary("small loop");
  // Pipelined, the global BA starts on a copy beside loop detection and is cancelled when a loop closes:
  // the trajectory must be the sequential run's, bit for bit.
  SlamOptions sequential = SmallSlam();
  sequential.parallel = false;
  const SlamRunReport s = RunSimulated(dir, sequential, /*use_priors=*/true, /*prior_noise_m=*/1.0);
  EXPECT_EQ(s.result.stats.loops_closed, r.result.stats.loops_closed);
  ASSERT_EQ(s.result.frames.poses.size(), r.result.frames.poses.size());
  for (size_t i = 0; i < r.result.frames.poses.size(); ++i)
    EXPECT_TRUE(r.result.frames.poses[i].T_world_frame.matrix() == s.result.frames.poses[i].T_world_frame.matrix())
        << "frame " << i;
}

// One-way flight over 30 m of road: dashes, edge lines and asphalt texture repeat their looks every
// few metres. The priors of the second half are moved onto the first half (as if the drone had come
// back), so prior proximity proposes look-alike but different road as loop candidates.
TEST(LoopClosing, LookAlikeRoadGivesNoFalseLoop) {
  SimulationOptions o = SmallRig(PresetOptions("demo"));
  o.num_frames = 60;  // 4 m/s at 12 Hz: 20 m
  o.road_length_m = 60;
  const fs::path dir = Rendered("lookalike", o);
  const StereoSource source = OpenStereoSource(dir, "plain");
  const Trajectory truth = ReadTrajectory(dir / "truth" / "trajectory.tum", TrajectoryFormat::kTum);
  ASSERT_EQ(truth.poses.size(), 60u);
  StereoSlam slam(*source.calibration(), SmallSlam());
  const int half = 30;
  for (int i = 0; i < 60; ++i) {
    PosePrior p;
    // Frame i >= 30 claims the position of frame 59 - i: the second half folds back over the first.
    p.T_world_cam = truth.poses[i < half ? i : 59 - i].T_world_frame;
    p.sigma_position_m = 1.0;
    const StereoFrame& f = source.frames()[i];
    slam.Track(f.t_ns, LoadGray8(f.left), LoadGray8(f.right), p);
  }
  const SlamResult r = slam.Finish();
  EXPECT_EQ(r.stats.tracked, 60);
  EXPECT_GT(r.stats.loop_candidates, 5) << "the folded priors must propose candidates, or this test tests nothing";
  EXPECT_EQ(r.stats.loops_closed, 0) << r.stats.BriefReport();
}

// The verification on its own: a keyframe of the return leg against an outbound keyframe over the same
// road is accepted with a relative pose that agrees with the truth; against an outbound keyframe 8 m
// away (look-alike road, no overlap) it is rejected.
TEST(LoopClosing, VerificationRelativePoseMatchesTruth) {
  const fs::path dir = Rendered("loop", SmallLoop());
  SlamOptions so = SmallSlam();
  so.loop_closure = false;
  so.global_ba_iterations = 0;
  const SlamRunReport r = RunSimulated(dir, so, false);
  const Trajectory truth = ReadTrajectory(dir / "truth" / "trajectory.tum", TrajectoryFormat::kTum);
  const SlamMap& map = r.result.map;
  const StereoSource source = OpenStereoSource(dir, "plain");
  const StereoCalibration& c = *source.calibration();
  const RectifiedStereo cam = RectifiedStereoOf(c);
  const ScalePyramid pyr(so.pyramid_levels, so.scale_factor);
  // The last keyframe (end of the return leg, near the start) and the outbound keyframes.
  const int q = static_cast<int>(map.keyframes.size()) - 1;
  const Eigen::Vector3d cq = TruthCentre(truth, map.keyframes[q].t_ns);
  int near = -1, far = -1;
  double best = 1e9;
  for (int k = 0; k < q - so.loop_min_gap_keyframes; ++k) {
    const double d = (TruthCentre(truth, map.keyframes[k].t_ns) - cq).norm();
    if (d < best) best = d, near = k;
    if (far < 0 && d > 8.0 && d < 9.5) far = k;
  }
  ASSERT_GE(near, 0);
  ASSERT_LT(best, 1.0);
  ASSERT_GE(far, 0);
  const LoopVerification v = VerifyLoopCandidate(map, q, near, cam, pyr, so.loop_min_inliers, 1);
  EXPECT_TRUE(v.accepted) << v.descriptor_matches << " matches, " << v.ransac_inliers << " RANSAC, " << v.inliers;
  // Truth relative pose of the two keyframes' cameras.
  auto truth_pose = [&](int64_t t) {
    for (const StampedPose& p : truth.poses)
      if (std::llabs(p.t_ns - t) < 1'000'000) return p.T_world_frame;
    return Eigen::Isometry3d::Identity();
  };
  const Eigen::Isometry3d T_true = truth_pose(map.keyframes[q].t_ns).inverse() * truth_pose(map.keyframes[near].t_ns);
  // A nadir view of flat road with a narrow field of view leaves a tilt about the ground and a shift of
  // the camera nearly interchangeable (1 deg of tilt ~ 0.1 m at 6 m), so the edge is checked where it is
  // determined: it must map the road point under the candidate's camera (6 m below) onto its true place
  // in the query's camera, and be within a few degrees overall.
  const Eigen::Vector3d ground(0, 0, 6.0);
  for (const Eigen::Isometry3d& T : {v.T_query_candidate, v.T_query_candidate_two_view}) {
    const double ground_err = (T * ground - T_true * ground).norm();
    const double rot_err = Eigen::AngleAxisd((T_true.inverse() * T).linear()).angle() * 180 / M_PI;
    std::printf("loop edge vs truth: road point under the candidate %.3f m, rotation %.2f deg\n", ground_err, rot_err);
    EXPECT_LT(ground_err, 0.03);
    EXPECT_LT(rot_err, 3.0);
  }
  const LoopVerification w = VerifyLoopCandidate(map, q, far, cam, pyr, so.loop_min_inliers, 1);
  EXPECT_FALSE(w.accepted) << w.descriptor_matches << " matches, " << w.ransac_inliers << " RANSAC, " << w.inliers;
}

// Runs SLAM over a rendered folder with frames [blank_from, blank_to) replaced by a uniform grey pair
// (a camera dropout: no features at all), priors = truth + `prior_sigma_m` noise (fixed seed).
struct DropoutRun {
  SlamResult result;
  std::vector<FrameResult> frames;
  Trajectory truth;
  AteResult ate;
  double path_m = 0;
};
DropoutRun RunWithDropout(const fs::path& dir, const SlamOptions& so, int blank_from, int blank_to,
                          double prior_sigma_m) {
  DropoutRun run;
  const StereoSource source = OpenStereoSource(dir, "plain");
  run.truth = ReadTrajectory(dir / "truth" / "trajectory.tum", TrajectoryFormat::kTum);
  StereoSlam slam(*source.calibration(), so);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0, prior_sigma_m);
  for (size_t i = 0; i < source.frames().size(); ++i) {
    const StereoFrame& f = source.frames()[i];
    PosePrior p;
    p.T_world_cam = run.truth.poses[i].T_world_frame;
    p.T_world_cam.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    p.sigma_position_m = prior_sigma_m;
    cv::Mat l = LoadGray8(f.left), r = LoadGray8(f.right);
    if (static_cast<int>(i) >= blank_from && static_cast<int>(i) < blank_to) {
      l.setTo(128);
      r.setTo(128);
    }
    run.frames.push_back(slam.Track(f.t_ns, l, r, p));
  }
  run.result = slam.Finish();
  const PosePairs pairs = AssociateByTimestamp(run.result.frames, run.truth, 1'000'000);
  run.ate = ComputeAte(pairs, TrajectoryAlignment::kSE3);
  for (size_t i = 1; i < run.truth.poses.size(); ++i)
    run.path_m +=
        (run.truth.poses[i].T_world_frame.translation() - run.truth.poses[i - 1].T_world_frame.translation()).norm();
  return run;
}

// A short dropout (2 frames, 0.67 m of flight at 12 Hz; the next frame still overlaps the last tracked one
// by half its 2.2 m footprint): the blank frames are placed by prediction (no features, so no map segment
// is started from them), and the next real frame finds the map again.
TEST(TrackingLoss, ShortDropoutIsBridgedAndTheMapFoundAgain) {
  SimulationOptions o = SmallRig(PresetOptions("demo"));
  o.num_frames = 60;
  o.road_length_m = 60;
  const fs::path dir = Rendered("lookalike", o);  // the same flight as LookAlikeRoadGivesNoFalseLoop
  const DropoutRun run = RunWithDropout(dir, SmallSlam(), 30, 32, 1.0);
  const DropoutRun clean = RunWithDropout(dir, SmallSlam(), 30, 30, 1.0);
  std::printf("short dropout: %s; ATE %.3f m (%.2f %% of %.1f m); without the dropout %.3f m\n",
              run.result.stats.BriefReport().c_str(), run.ate.translation_m.rmse,
              100 * run.ate.translation_m.rmse / run.path_m, run.path_m, clean.ate.translation_m.rmse);
  for (int i = 0; i < 60; ++i) {
    const bool blank = i >= 30 && i < 32;
    EXPECT_EQ(run.frames[i].status == FrameStatus::kPriorOnly, blank) << "frame " << i;
    if (blank) EXPECT_LT(run.frames[i].gnss_weight, 0.01) << "0.2 s of extrapolation beats 1 m GNSS noise";
  }
  EXPECT_EQ(run.result.stats.segments, 1) << "blank frames must not start map segments";
  // The blank frames' predicted motion since the last tracked frame (29) matches the true motion (0.35 and
  // 0.69 m flown; compared in the truth frame via the ATE alignment's rotation) within 0.08 m: the
  // extrapolation inherits the map's own along-track scale over the second before, several % off on
  // this narrow rig (measured 0.03 and 0.06 m).
  const Eigen::Matrix3d R = run.ate.alignment.R;
  for (int i = 30; i < 32; ++i) {
    const Eigen::Vector3d est = R * (run.result.frames.poses[i].T_world_frame.translation() -
                                     run.result.frames.poses[29].T_world_frame.translation());
    const Eigen::Vector3d truth =
        run.truth.poses[i].T_world_frame.translation() - run.truth.poses[29].T_world_frame.translation();
    EXPECT_LT((est - truth).norm(), 0.08) << "frame " << i << " moved " << est.norm() << " m, truly " << truth.norm();
  }
  // This narrow one-way flight drifts (~3 % without any dropout, the front end's tilt/shift ambiguity);
  // the dropout must not make it worse by more than 0.05 m.
  EXPECT_LT(run.ate.translation_m.rmse, clean.ate.translation_m.rmse + 0.05);
}

// A long dropout (2.5 m of flight, more than the 2.2 m footprint) on the outbound leg of an
// out-and-back flight: the first frame after it sees no mapped road, so a new map segment starts
// there, seeded by the prediction (and the flight log); the return leg overlaps both segments and its
// loops merge them into one consistent trajectory.
TEST(TrackingLoss, NewSegmentIsMergedByTheReturnLeg) {
  const fs::path dir = Rendered("loop", SmallLoop());
  const DropoutRun run = RunWithDropout(dir, SmallSlam(), 10, 15, 0.3);
  const DropoutRun clean = RunWithDropout(dir, SmallSlam(), 10, 10, 0.3);
  std::printf("long dropout: %s; ATE %.3f m (%.2f %% of %.1f m); without the dropout %.3f m\n",
              run.result.stats.BriefReport().c_str(), run.ate.translation_m.rmse,
              100 * run.ate.translation_m.rmse / run.path_m, run.path_m, clean.ate.translation_m.rmse);
  for (int i = 10; i < 15; ++i) EXPECT_EQ(run.frames[i].status, FrameStatus::kPriorOnly) << "frame " << i;
  ASSERT_GE(run.result.stats.segments, 2) << "the frame after the dropout should have started a segment";
  // A loop links a keyframe with one of another segment: the segments are merged.
  int merging = 0;
  for (const LoopClosure& l : run.result.loops)
    merging += run.result.map.keyframes[l.keyframe].segment != run.result.map.keyframes[l.loop_keyframe].segment;
  EXPECT_GE(merging, 1) << run.result.stats.BriefReport();
  // Merged, the trajectory stays close to the run without the 2.5 m gap (the new segment's start
  // pose is only predicted; the loop edges pin it). Measured: 0.243 m against 0.118 m (since the
  // simulator's anisotropic texture filter, docs/simulator.md, the sharper far road helped the clean
  // run, 0.135 -> 0.118 m, not the merged one, 0.234 -> 0.243 m; with the former global BA
  // parametrisation 0.198 against 0.154 m). Unmerged, the second segment keeps the predicted
  // offset: several times the clean run's ATE.
  EXPECT_LT(run.ate.translation_m.rmse, 2.5 * clean.ate.translation_m.rmse);
}

// A full-size car rig on a bend (radius 50 m, 73 degrees over 63.5 m): its camera sees only the road
// 2.7-3.8 m ahead, 0.53 m of travel per frame, so two frames after a keyframe little of that keyframe's
// map is left. At one frame the local map gives 19 inliers (< min_tracked_inliers 20) while the
// previous frame's stereo points give 174 of 178: the frame must be kept by them (and made a
// keyframe), not lost and the map split.
TEST(TrackingLoss, FastCarViewIsHeldByTheLastFramesStereoPoints) {
  SimulationOptions o = PresetOptions("car");
  o.road_curvature_1_m = 0.02;
  o.num_frames = 120;
  const fs::path dir = Rendered("car_bend", o);
  const SlamRunReport r = RunSimulated(dir, SlamOptions{}, false);
  const SlamStatistics& s = r.result.stats;
  EXPECT_EQ(s.tracked, 120) << s.BriefReport();
  EXPECT_GE(s.held_by_odometry, 1) << s.BriefReport();
  EXPECT_EQ(s.segments, 1) << s.BriefReport();
  // 0.099 % of the path measured; the bound is the loop's 0.2 %.
  EXPECT_LT(r.ate.translation_m.rmse, 0.002 * r.path_length_m);
}

// A car rig whose camera sees only the road 2.7-4.6 m ahead: the first frame's depths are shallow, so
// the regime is chosen by the motion (along the optical axis: forward) at frame 1, which raises the
// feature count for frame 2 on. Pipelined and sequential runs must stay bit-identical through that.
TEST(Regime, ShallowCarViewIsForwardByItsMotion) {
  SimulationOptions o = SmallRig(PresetOptions("car"));
  o.num_frames = 12;
  const fs::path dir = Rendered("car", o);
  SlamOptions opt;
  const SlamRunReport piped = RunSimulated(dir, opt, false);
  opt.parallel = false;
  const SlamRunReport sequential = RunSimulated(dir, opt, false);
  const SlamStatistics& s = piped.result.stats;
  EXPECT_EQ(s.regime, SlamRegime::kForward) << s.regime_reason;
  EXPECT_NE(s.regime_reason.find("optical axis"), std::string::npos) << s.regime_reason;
  EXPECT_EQ(s.tracked, 12);
  ASSERT_EQ(piped.frames.size(), 12u);
  EXPECT_LE(piped.frames[1].features, 1200);  // before the choice: the options as given
  EXPECT_GT(piped.frames[2].features, 1200);  // after it: the forward regime's 2000
  ASSERT_EQ(piped.result.frames.poses.size(), sequential.result.frames.poses.size());
  for (size_t i = 0; i < piped.result.frames.poses.size(); ++i)
    EXPECT_TRUE(piped.result.frames.poses[i].T_world_frame.matrix() ==
                sequential.result.frames.poses[i].T_world_frame.matrix())
        << "frame " << i;
}

}  // namespace
}  // namespace rs
