#include "stages/refine/gauge.h"

#include <gtest/gtest.h>

#include <random>

namespace rs {
namespace {

Eigen::Isometry3d Pose(double yaw, double pitch, double roll, Eigen::Vector3d t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

TEST(Gauge, LogExpRoundTrip) {
  for (double a : {0.0, 1e-9, 0.3, 3.0}) {
    const Eigen::Isometry3d T = Pose(a, -0.5 * a, 0.2 * a, Eigen::Vector3d(1, -2, 3));
    EXPECT_TRUE(ExpSE3(LogSE3(T)).isApprox(T, 1e-12)) << a;
  }
}

// A refined trajectory that is the SLAM one moved rigidly comes back exactly, whichever anchor.
TEST(Gauge, RigidMotionIsUndoneExactly) {
  std::vector<Eigen::Isometry3d> slam, moved;
  const Eigen::Isometry3d M = Pose(0.7, 0.1, -0.2, Eigen::Vector3d(5, -3, 2));
  for (int i = 0; i < 20; ++i) {
    slam.push_back(Pose(0.05 * i, 0, 0, Eigen::Vector3d(2.0 * i, 0.1 * i * i, 0)));  // nearly straight
    moved.push_back(M * slam.back());
  }
  for (GaugeAnchor a : {GaugeAnchor::kFirstKeyframe, GaugeAnchor::kKeyframes}) {
    const Eigen::Isometry3d G = GaugeTransform(slam, moved, a);
    for (size_t i = 0; i < slam.size(); ++i) EXPECT_TRUE((G * moved[i]).isApprox(slam[i], 1e-12));
  }
}

// Keyframes as refined exactly; frames between them moved by the SE(3) geodesic of the corrections;
// a frame at a keyframe's instant keeps its pose relative to that keyframe.
TEST(Gauge, CarryInterpolatesCorrectionsOnSe3) {
  const Eigen::Isometry3d C0 = Pose(0.01, 0, 0, Eigen::Vector3d(0.1, 0, 0));
  const Eigen::Isometry3d C1 = Pose(-0.02, 0.01, 0, Eigen::Vector3d(0, 0.2, -0.1));
  Trajectory slam;
  for (int i = 0; i <= 10; ++i) slam.poses.push_back({i * 100, Pose(0.1 * i, 0, 0, Eigen::Vector3d(i, 0, 0))});
  const Trajectory out = CarryTrajectory(slam, {{1000, C1}, {200, C0}});  // unsorted on purpose
  for (int i = 0; i <= 10; ++i) {
    const int64_t t = i * 100;
    Eigen::Isometry3d C;
    if (t <= 200) C = C0;
    else if (t >= 1000) C = C1;
    else C = C0 * ExpSE3((t - 200) / 800.0 * LogSE3(C0.inverse() * C1));
    EXPECT_TRUE(out.poses[i].T_world_frame.isApprox(C * slam.poses[i].T_world_frame, 1e-12)) << i;
  }
  // Midway: the correction is the geodesic midpoint, i.e. applying it twice from C0 gives C1.
  const Eigen::Isometry3d mid = out.poses[6].T_world_frame * slam.poses[6].T_world_frame.inverse();
  EXPECT_TRUE((mid * C0.inverse() * mid).isApprox(C1, 1e-12));
}

}  // namespace
}  // namespace rs
