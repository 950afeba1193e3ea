#include "stages/slam/pose_optimizer.h"

#include <random>

#include <gtest/gtest.h>

namespace rs {
namespace {

RectifiedStereo TestCamera() {
  RectifiedStereo c;
  c.f_px = 700;
  c.cx_px = 600;
  c.cy_px = 180;
  c.baseline_m = 0.5;
  c.width = 1226;
  c.height = 370;
  return c;
}

// Points seen from T_true with exact stereo measurements; 20 % gross outliers.
std::vector<PoseObservation> MakeObservations(const RectifiedStereo& cam, const Eigen::Isometry3d& T_cam_world,
                                              std::mt19937* rng, std::vector<bool>* is_outlier) {
  std::uniform_real_distribution<double> ux(-10, 10), uy(-3, 3), uz(4, 40), bad(-30, 30);
  std::vector<PoseObservation> obs;
  const Eigen::Isometry3d T_world_cam = T_cam_world.inverse();
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d pc(ux(*rng), uy(*rng), uz(*rng));
    PoseObservation o;
    o.p_world = T_world_cam * pc;
    o.u = cam.f_px * pc.x() / pc.z() + cam.cx_px;
    o.v = cam.f_px * pc.y() / pc.z() + cam.cy_px;
    o.u_right = i % 3 == 0 ? -1 : o.u - cam.bf() / pc.z();
    o.inv_sigma2 = 1;
    const bool out = i % 5 == 0;
    if (out) {
      const double du = bad(*rng), dv = bad(*rng);
      o.u += du + (du < 0 ? -8 : 8);  // at least 8 px off: unambiguous outliers
      o.v += dv;
    }
    is_outlier->push_back(out);
    obs.push_back(o);
  }
  return obs;
}

TEST(PoseOptimizer, Nominal) {
  const RectifiedStereo cam = TestCamera();
  std::mt19937 rng(3);
  Eigen::Isometry3d T_true = Eigen::Isometry3d::Identity();
  T_true.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  T_true.translation() = Eigen::Vector3d(0.5, -0.2, 1.3);
  std::vector<bool> truth_outlier;
  std::vector<PoseObservation> obs = MakeObservations(cam, T_true, &rng, &truth_outlier);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.32, Eigen::Vector3d(0.25, 1, 0.1).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.6, -0.1, 1.0);
  const int inliers = OptimizePose(cam, &obs, &T);
  EXPECT_NEAR((T.translation() - T_true.translation()).norm(), 0, 1e-6);
  EXPECT_NEAR(Eigen::AngleAxisd(T.linear().transpose() * T_true.linear()).angle(), 0, 1e-8);
  int correct = 0;
  for (size_t i = 0; i < obs.size(); ++i) correct += obs[i].outlier == truth_outlier[i];
  EXPECT_EQ(correct, static_cast<int>(obs.size()));
  EXPECT_EQ(inliers, 240);
}

TEST(PoseOptimizer, TooFewObservations) {
  std::vector<PoseObservation> obs(2);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  EXPECT_EQ(OptimizePose(TestCamera(), &obs, &T), 0);
  EXPECT_TRUE(T.isApprox(Eigen::Isometry3d::Identity()));
}

}  // namespace
}  // namespace rs
