#include "eval/trajectory/trajectory_metrics.h"
#include "tests/support/test_data.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "formats/input_error.h"
#include "formats/trajectory/trajectory_file.h"
#include "eval/trajectory/trajectory_transform.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

fs::path EvoData() { return rs::test::DataRoot() / "kitti_euroc_trajectories" / "evo" / "test" / "data"; }

#define SKIP_WITHOUT_EVO_DATA() \
  if (!fs::exists(EvoData()))   \
  GTEST_SKIP() << "real trajectories not found at " << EvoData() << " (set ROADSURVEY_DATA to the shared data folder)"

Eigen::Matrix3d Rz(double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

Trajectory Make(const std::vector<Eigen::Isometry3d>& poses, int64_t period_ns = 100'000'000, int64_t t0_ns = 0) {
  Trajectory t;
  t.source = "mem";
  for (size_t i = 0; i < poses.size(); ++i) t.poses.push_back({t0_ns + static_cast<int64_t>(i) * period_ns, poses[i]});
  return t;
}

Eigen::Isometry3d Pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = p;
  return T;
}

const Trajectory& Kitti00Gt() {
  static const Trajectory t =
      ReadTrajectory(EvoData() / "KITTI_00_gt.txt", TrajectoryFormat::kKitti, EvoData() / "KITTI_00_gt_times.txt");
  return t;
}

TEST(UmeyamaAlignment, HandMade) {
  // Four points, mapped by a 90 degree yaw, scale 2 and a shift: the fit must be exact.
  Eigen::Matrix3Xd est(3, 4), gt(3, 4);
  est << 0, 1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 3;
  // By hand: Rz(90) (x, y, z) = (-y, x, z); gt = 2 * Rz(90) est + (1, 2, 3).
  gt << 1, 1, -3, 1, 2, 4, 2, 2, 3, 3, 3, 9;
  const Sim3Transform s = UmeyamaAlignment(est, gt, TrajectoryAlignment::kSim3);
  EXPECT_NEAR(s.scale, 2.0, 1e-12);
  EXPECT_TRUE(s.R.isApprox(Rz(M_PI / 2), 1e-12)) << s.R;
  EXPECT_TRUE(s.t.isApprox(Eigen::Vector3d(1, 2, 3), 1e-12)) << s.t.transpose();

  // Rigid data: SE(3) is exact too, and kNone is the identity.
  const Eigen::Matrix3Xd rigid = (Rz(0.3) * est).colwise() + Eigen::Vector3d(-5, 0.5, 2);
  const Sim3Transform r = UmeyamaAlignment(est, rigid, TrajectoryAlignment::kSE3);
  EXPECT_EQ(r.scale, 1.0);
  EXPECT_TRUE(r.R.isApprox(Rz(0.3), 1e-12));
  EXPECT_TRUE(r.t.isApprox(Eigen::Vector3d(-5, 0.5, 2), 1e-12));
  const Sim3Transform none = UmeyamaAlignment(est, rigid, TrajectoryAlignment::kNone);
  EXPECT_TRUE(none.R.isIdentity() && none.t.isZero() && none.scale == 1.0);
}

TEST(UmeyamaAlignment, MatchesEigenUmeyama) {
  // Eigen's own implementation as an independent reference on noisy, non-degenerate data.
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3Xd est(3, 37), gt(3, 37);
  for (int i = 0; i < 37; ++i) {
    est.col(i) = Eigen::Vector3d(n(rng), n(rng), n(rng)) * 10;
    gt.col(i) = 0.7 * Rz(2.0) * Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()) * est.col(i) +
                Eigen::Vector3d(3, 4, 5) + Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
  for (bool with_scale : {false, true}) {
    const Eigen::Matrix4d ref = Eigen::umeyama(est, gt, with_scale);
    const Sim3Transform s =
        UmeyamaAlignment(est, gt, with_scale ? TrajectoryAlignment::kSim3 : TrajectoryAlignment::kSE3);
    const double ref_scale = ref.block<3, 1>(0, 0).norm();
    EXPECT_NEAR(s.scale, ref_scale, 1e-10);
    EXPECT_TRUE((s.scale * s.R).isApprox(ref.topLeftCorner<3, 3>(), 1e-10));
    EXPECT_TRUE(s.t.isApprox(ref.topRightCorner<3, 1>(), 1e-10));
  }
}

TEST(UmeyamaAlignment, Reflection) {
  // A mirrored point set must still get a proper rotation (det +1), never a reflection.
  Eigen::Matrix3Xd est(3, 4);
  est << 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
  Eigen::Matrix3Xd gt = est;
  gt.row(2) *= -1;
  const Sim3Transform s = UmeyamaAlignment(est, gt, TrajectoryAlignment::kSE3);
  EXPECT_NEAR(s.R.determinant(), 1.0, 1e-12);
}

TEST(UmeyamaAlignment, Degenerate) {
  Eigen::Matrix3Xd line(3, 5);
  for (int i = 0; i < 5; ++i) line.col(i) = Eigen::Vector3d(i, 2 * i, 0);
  EXPECT_THROW(UmeyamaAlignment(line, line, TrajectoryAlignment::kSE3), std::invalid_argument);
  EXPECT_THROW(UmeyamaAlignment(line.leftCols(2), line.leftCols(2), TrajectoryAlignment::kSim3), std::invalid_argument);
  EXPECT_THROW(UmeyamaAlignment(line, line.leftCols(4), TrajectoryAlignment::kSE3), std::invalid_argument);
  const Eigen::Matrix3Xd same = Eigen::Matrix3Xd::Ones(3, 6);
  EXPECT_THROW(UmeyamaAlignment(same, same, TrajectoryAlignment::kSE3), std::invalid_argument);
}

TEST(ComputeErrorStats, Nominal) {
  const ErrorStats s = ComputeErrorStats({3, 1, 4, 1, 5, 9});
  EXPECT_EQ(s.count, 6u);
  EXPECT_DOUBLE_EQ(s.mean, 23.0 / 6);
  EXPECT_DOUBLE_EQ(s.median, 3.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(133.0 / 6));
  EXPECT_NEAR(s.std, std::sqrt(133.0 / 6 - (23.0 / 6) * (23.0 / 6)), 1e-12);
  EXPECT_EQ(s.min, 1);
  EXPECT_EQ(s.max, 9);
  EXPECT_DOUBLE_EQ(ComputeErrorStats({2, 7, 4}).median, 4);
  EXPECT_EQ(ComputeErrorStats({}).count, 0u);
}

TEST(Association, Nominal) {
  std::vector<Eigen::Isometry3d> p(5, Eigen::Isometry3d::Identity());
  Trajectory gt = Make(p, 100);  // t = 0, 100, ..., 400 ns
  Trajectory est = Make(std::vector<Eigen::Isometry3d>(4, Eigen::Isometry3d::Identity()), 100, 1000);
  est.poses[0].t_ns = 1000 + 3;    // -> gt 0 (offset -1000)
  est.poses[1].t_ns = 1000 + 148;  // -> gt 100 (diff 48), gt 200 is 52 away
  est.poses[2].t_ns = 1000 + 160;  // gt 200 (diff 40)
  est.poses[3].t_ns = 1000 + 390;  // gt 400 (diff 10)
  PosePairs pairs = AssociateByTimestamp(est, gt, 50, -1000);
  ASSERT_EQ(pairs.size(), 4u);
  EXPECT_EQ(pairs.gt_index, (std::vector<size_t>{0, 1, 2, 4}));
  EXPECT_EQ(pairs.t_ns[1], 1148);
  pairs = AssociateByTimestamp(est, gt, 20, -1000);  // 48 and 40 exceed the tolerance
  EXPECT_EQ(pairs.est_index, (std::vector<size_t>{0, 3}));
  // One-to-one: two estimates near the same ground-truth pose, the closer one wins.
  est.poses[1].t_ns = 1000 + 195;
  pairs = AssociateByTimestamp(est, gt, 50, -1000);
  EXPECT_EQ(pairs.est_index, (std::vector<size_t>{0, 1, 3}));
  EXPECT_EQ(pairs.gt_index, (std::vector<size_t>{0, 2, 4}));
}

TEST(Association, Malformed) {
  Trajectory gt = Make(std::vector<Eigen::Isometry3d>(5, Eigen::Isometry3d::Identity()));
  Trajectory est = Make(std::vector<Eigen::Isometry3d>(4, Eigen::Isometry3d::Identity()));
  est.source = "est.txt";
  EXPECT_THROW(AssociateByIndex(est, gt), InputError);
  EXPECT_THROW(AssociateByTimestamp(est, gt, 0, std::numeric_limits<int64_t>::max()), std::invalid_argument);
  est.has_times = false;
  try {
    AssociateByTimestamp(est, gt, 1000);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "est.txt");
  }
}

TEST(Ate, Identical) {
  SKIP_WITHOUT_EVO_DATA();
  const Trajectory& gt = Kitti00Gt();
  const PosePairs pairs = AssociateByTimestamp(gt, gt, 0);
  ASSERT_EQ(pairs.size(), 4541u);
  for (TrajectoryAlignment a : {TrajectoryAlignment::kNone, TrajectoryAlignment::kSE3, TrajectoryAlignment::kSim3}) {
    const AteResult ate = ComputeAte(pairs, a);
    EXPECT_LT(ate.translation_m.max, 1e-9) << TrajectoryAlignmentName(a);
    EXPECT_LT(ate.rotation_deg.max, 1e-6);
    EXPECT_NEAR(ate.alignment.scale, 1.0, 1e-12);
    EXPECT_TRUE(ate.alignment.R.isIdentity(1e-12));
  }
  const RpeResult rpe = ComputeRpe(pairs, {1, RelativeDelta::Unit::kFrames});
  EXPECT_EQ(rpe.translation_stats_m.count, 4540u);
  EXPECT_LT(rpe.translation_stats_m.max, 1e-9);
  EXPECT_LT(rpe.rotation_stats_deg.max, 1e-6);
  EXPECT_LT(ComputeRde(pairs, {10, RelativeDelta::Unit::kMeters}).stats_m.max, 1e-9);
  const KittiOdometryResult k = ComputeKittiOdometry(pairs, {});
  EXPECT_GT(k.segments, 1000u);
  EXPECT_LT(k.t_err_percent, 1e-9);
  EXPECT_LT(k.r_err_deg_per_100m, 1e-6);
}

// KITTI 00 ground truth moved by a known Sim(3) plus isotropic Gaussian noise sigma per axis:
// the alignment must recover the transform and the ATE must be the noise's (Maxwell) statistics.
TEST(Ate, KittiPerturbed) {
  SKIP_WITHOUT_EVO_DATA();
  const Trajectory& gt = Kitti00Gt();
  const Eigen::Matrix3d R_true = Rz(0.8) * Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d t_true(120.0, -45.0, 7.5);
  const double sigma_m = 0.2;  // in the estimate's frame; the ATE sees s * sigma

  for (TrajectoryAlignment mode : {TrajectoryAlignment::kSE3, TrajectoryAlignment::kSim3}) {
    const double s_true = mode == TrajectoryAlignment::kSim3 ? 2.5 : 1.0;
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0.0, sigma_m);
    Trajectory est = gt;
    for (StampedPose& p : est.poses) {
      // est = S^-1(gt) + noise, so S(est) = gt + s * noise.
      const Eigen::Vector3d p_est = R_true.transpose() * (p.T_world_frame.translation() - t_true) / s_true;
      p.T_world_frame = Pose(R_true.transpose() * p.T_world_frame.linear(),
                             p_est + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
    const AteResult ate = ComputeAte(AssociateByIndex(est, gt), mode);
    const double angle_err = RotationAngleRad(ate.alignment.R.transpose() * R_true);
    EXPECT_LT(angle_err, 1e-4) << "rotation recovered within 1e-4 rad";
    EXPECT_LT((ate.alignment.t - t_true).norm(), 0.05);
    EXPECT_NEAR(ate.alignment.scale, s_true, 1e-3 * s_true);
    // |s * noise| follows a Maxwell distribution with parameter a = s sigma: RMSE sqrt(3) a,
    // mean 2 sqrt(2/pi) a, std sqrt(3 - 8/pi) a, median 1.5382 a. 4541 samples: ~1% sampling error, 3% allowed.
    const double a = s_true * sigma_m;
    EXPECT_NEAR(ate.translation_m.rmse, std::sqrt(3.0) * a, 0.03 * std::sqrt(3.0) * a);
    EXPECT_NEAR(ate.translation_m.mean, 2 * std::sqrt(2 / M_PI) * a, 0.03 * 1.596 * a);
    EXPECT_NEAR(ate.translation_m.std, std::sqrt(3 - 8 / M_PI) * a, 0.03 * 0.673 * a);
    EXPECT_NEAR(ate.translation_m.median, 1.5382 * a, 0.03 * 1.5382 * a);
    EXPECT_LT(ate.rotation_deg.max, 0.01);  // orientations carry no noise
  }
}

TEST(Rde, Nominal) {
  // Along x at 1 m per frame; the estimate is 10% too long.
  std::vector<Eigen::Isometry3d> g, e;
  for (int i = 0; i < 5; ++i) {
    g.push_back(Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(i, 0, 0)));
    e.push_back(Pose(Rz(0.1 * i), Eigen::Vector3d(1.1 * i, 0, 0)));
  }
  const PosePairs pairs = AssociateByIndex(Make(e), Make(g));
  RdeResult r = ComputeRde(pairs, {1, RelativeDelta::Unit::kFrames});
  ASSERT_EQ(r.errors_m.size(), 4u);
  for (double v : r.errors_m) EXPECT_NEAR(v, 0.1, 1e-12);
  r = ComputeRde(pairs, {2, RelativeDelta::Unit::kFrames});
  ASSERT_EQ(r.errors_m.size(), 3u);
  EXPECT_NEAR(r.stats_m.mean, 0.2, 1e-12);
  r = ComputeRde(pairs, {1.5, RelativeDelta::Unit::kMeters});  // j = i + 2 (first at >= 1.5 m of travel)
  EXPECT_EQ(r.errors_m.size(), 3u);
  EXPECT_NEAR(r.stats_m.max, 0.2, 1e-12);
  r = ComputeRde(pairs,
                 {0.25, RelativeDelta::Unit::kSeconds});  // 0.1 s per frame: nearest to +0.25 s is i + 2 or i + 3
  EXPECT_GE(r.errors_m.size(), 2u);
  r = ComputeRde(pairs, {1, RelativeDelta::Unit::kFrames}, 1 / 1.1);  // scale corrected
  EXPECT_LT(r.stats_m.max, 1e-12);
  EXPECT_EQ(ComputeRde(pairs, {10, RelativeDelta::Unit::kFrames}).stats_m.count, 0u);
  EXPECT_THROW(ComputeRde(pairs, {1.5, RelativeDelta::Unit::kFrames}), std::invalid_argument);
  EXPECT_THROW(ComputeRde(pairs, {0, RelativeDelta::Unit::kMeters}), std::invalid_argument);
}

TEST(Rpe, Nominal) {
  // Ground truth: 1 m per frame along x, no rotation. Estimate: same positions, yaw grows by theta per frame.
  // Closed form for delta = 1 frame: E_i = (I, (1,0,0))^-1 (Rz(theta), Rz(-i theta)(1,0,0)),
  // so angle(E_i) = theta and |trans(E_i)| = |Rz(-i theta)(1,0,0) - (1,0,0)| = 2 sin(i theta / 2).
  const double theta = 0.01;
  std::vector<Eigen::Isometry3d> g, e;
  for (int i = 0; i < 50; ++i) {
    g.push_back(Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(i, 0, 0)));
    e.push_back(Pose(Rz(i * theta), Eigen::Vector3d(i, 0, 0)));
  }
  const RpeResult r = ComputeRpe(AssociateByIndex(Make(e), Make(g)), {1, RelativeDelta::Unit::kFrames});
  ASSERT_EQ(r.translation_m.size(), 49u);
  for (size_t i = 0; i < 49; ++i) {
    EXPECT_NEAR(r.translation_m[i], 2 * std::sin(i * theta / 2), 1e-12);
    EXPECT_NEAR(r.rotation_deg[i], theta * 180 / M_PI, 1e-9);
  }
  // Seconds: frames are 0.1 s apart, so 0.3 s is 3 frames and the rotation error is 3 theta.
  const RpeResult r3 = ComputeRpe(AssociateByIndex(Make(e), Make(g)), {0.3, RelativeDelta::Unit::kSeconds});
  EXPECT_EQ(r3.rotation_deg.size(), 47u);
  EXPECT_NEAR(r3.rotation_stats_deg.mean, 3 * theta * 180 / M_PI, 1e-9);
}

// Closed forms for the KITTI devkit semantics: straight 1000 m drive along z, 1 m per frame.
TEST(KittiOdometry, Nominal) {
  std::vector<Eigen::Isometry3d> g, scaled, yawing;
  const double theta = 1e-4;  // rad per frame about the direction of travel
  for (int i = 0; i <= 1000; ++i) {
    g.push_back(Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, i)));
    scaled.push_back(Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 1.01 * i)));
    yawing.push_back(Pose(Rz(theta * i), Eigen::Vector3d(0, 0, i)));
  }
  KittiOdometryOptions o;
  o.lengths_m = {100};
  // The segment ends at the first frame with travel strictly > 100 m: 101 frames later; starts every 10
  // frames while first + 101 <= 1000, i.e. 90 segments; error 1% of 101 m over L = 100 m.
  KittiOdometryResult k = ComputeKittiOdometry(AssociateByIndex(Make(scaled), Make(g)), o);
  EXPECT_EQ(k.segments, 90u);
  EXPECT_NEAR(k.t_err_percent, 1.01, 1e-9);
  EXPECT_NEAR(k.r_err_deg_per_100m, 0.0, 1e-9);
  // Rotation about the travel axis leaves translation exact; angle 101 theta over 100 m.
  k = ComputeKittiOdometry(AssociateByIndex(Make(yawing), Make(g)), o);
  EXPECT_NEAR(k.t_err_percent, 0.0, 1e-9);
  EXPECT_NEAR(k.r_err_deg_per_100m, 101 * theta / 100 * 180 / M_PI * 100, 1e-9);
  // Default lengths 100..800: per-length errors are 1% (L + 1) / L each.
  k = ComputeKittiOdometry(AssociateByIndex(Make(scaled), Make(g)), {});
  ASSERT_EQ(k.per_length.size(), 8u);
  for (const auto& p : k.per_length) {
    EXPECT_NEAR(p.t_err_percent, (p.length_m + 1) / p.length_m, 1e-9) << p.length_m;
    EXPECT_EQ(p.segments, static_cast<size_t>((999 - static_cast<int>(p.length_m)) / 10 + 1)) << p.length_m;
  }
}

TEST(KittiOdometry, ShortSequence) {
  std::vector<Eigen::Isometry3d> g;
  for (int i = 0; i <= 50; ++i) g.push_back(Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(i, 0, 0)));
  const PosePairs pairs = AssociateByIndex(Make(g), Make(g));
  KittiOdometryResult k = ComputeKittiOdometry(pairs, {});
  ASSERT_EQ(k.used_lengths_m.size(), 8u);
  EXPECT_NEAR(k.used_lengths_m[0], 5.0, 1e-12);
  EXPECT_GT(k.segments, 0u);
  KittiOdometryOptions strict;
  strict.shorten_for_short_sequences = false;
  EXPECT_EQ(ComputeKittiOdometry(pairs, strict).segments, 0u);
  strict.step_frames = 0;
  EXPECT_THROW(ComputeKittiOdometry(pairs, strict), std::invalid_argument);
}

TEST(ApplyExtrinsic, Nominal) {
  // Body yawed 90 degrees at (1, 2, 3); camera 0.1 m along body x, looking along body -z.
  Trajectory body = Make({Pose(Rz(M_PI / 2), Eigen::Vector3d(1, 2, 3))});
  const Eigen::Matrix3d R_body_cam = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Trajectory cam = ApplyExtrinsic(body, Pose(R_body_cam, Eigen::Vector3d(0.1, 0, 0)));
  // Body x is world y, so the camera sits at (1, 2.1, 3); its z axis is world -z.
  EXPECT_TRUE(cam.poses[0].T_world_frame.translation().isApprox(Eigen::Vector3d(1, 2.1, 3), 1e-12));
  EXPECT_TRUE(
      (cam.poses[0].T_world_frame.linear() * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitZ(), 1e-12));
  EXPECT_EQ(cam.poses[0].t_ns, body.poses[0].t_ns);
}

}  // namespace
}  // namespace rs
