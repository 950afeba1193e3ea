#include "stages/slam/bundle_adjust.h"

#include <random>

#include "stages/slam/bundle_adjust_solver.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

namespace rs {
namespace {

// Autodiff Jacobians of the residuals against central differences (Ceres' NumericDiffCostFunction).
TEST(ReprojectionResidual, JacobiansMatchNumeric) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> small(-0.3, 0.3);
  for (int stereo = 0; stereo < 2; ++stereo) {
    ReprojectionResidual r{640.3, 200.7, stereo ? 610.2 : -1.0, 700, 705, 600, 180, 0.5, 1 / 1.2};
    double pose[6] = {small(rng), small(rng), small(rng), small(rng), small(rng), small(rng)};
    double point[3] = {1.5, -0.7, 9.0};
    double* params[2] = {pose, point};
    ceres::AutoDiffCostFunction<ReprojectionResidual, 3, 6, 3> ad(new ReprojectionResidual(r));
    ceres::NumericDiffCostFunction<ReprojectionResidual, ceres::CENTRAL, 3, 6, 3> nd(new ReprojectionResidual(r));
    double ra[3], rn[3], ja0[18], ja1[9], jn0[18], jn1[9];
    double* ja[2] = {ja0, ja1};
    double* jn[2] = {jn0, jn1};
    ASSERT_TRUE(ad.Evaluate(params, ra, ja));
    ASSERT_TRUE(nd.Evaluate(params, rn, jn));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(ra[i], rn[i], 1e-12);
    for (int i = 0; i < 18; ++i) EXPECT_NEAR(ja0[i], jn0[i], 1e-5 * (1 + std::abs(jn0[i]))) << i;
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(ja1[i], jn1[i], 1e-5 * (1 + std::abs(jn1[i]))) << i;
  }
}

// The analytic Jacobians the BA uses against autodiff, mono and stereo, at general rotations and at
// (near-)zero rotation where the left Jacobian's series takes over.
TEST(ReprojectionResidual, AnalyticJacobiansMatchAutodiff) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> angle(-1.5, 1.5), shift(-2, 2);
  for (int trial = 0; trial < 40; ++trial) {
    const bool stereo = trial % 2 == 0;
    ReprojectionResidual r{640.3, 200.7, stereo ? 610.2 : -1.0, 700, 705, 600, 180, 0.5, 1 / 1.44};
    const double scale = trial < 4 ? (trial < 2 ? 0.0 : 1e-9) : 1.0;  // zero and tiny rotations first
    double pose[6] = {scale * angle(rng), scale * angle(rng), scale * angle(rng), shift(rng), shift(rng), shift(rng)};
    double point[3] = {shift(rng), shift(rng), 12 + 3 * shift(rng)};
    double* params[2] = {pose, point};
    ceres::AutoDiffCostFunction<ReprojectionResidual, 3, 6, 3> ad(new ReprojectionResidual(r));
    double ra[3], ja0[18], ja1[9], rb[3], jb0[18], jb1[9];
    double* ja[2] = {ja0, ja1};
    ASSERT_TRUE(ad.Evaluate(params, ra, ja));
    EvaluateReprojection(r, pose, point, rb, jb0, jb1);
    // Near zero Ceres' rotation is first order (its derivative -[x]_x is off by O(|w| |x|)); the
    // analytic one is exact: 1e-6 there, 1e-8 elsewhere (a wrong formula would be O(1) off).
    const double tol = scale < 1 ? 1e-6 : 1e-8;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-9 * (1 + std::abs(ra[i]))) << trial;
    for (int i = 0; i < 18; ++i) EXPECT_NEAR(ja0[i], jb0[i], tol * (1 + std::abs(ja0[i]))) << trial << " pose " << i;
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(ja1[i], jb1[i], tol * (1 + std::abs(ja1[i]))) << trial << " point " << i;
  }
}

TEST(RelativePoseResidual, JacobiansMatchNumeric) {
  RelativePoseResidual r;
  r.q_a_b = Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.3, 1, 0.2).normalized()));
  r.t_a_b = Eigen::Vector3d(1, -2, 0.5);
  double a[6] = {0.1, -0.2, 0.05, 1, 2, 3}, b[6] = {0.2, 0.1, -0.1, 2, 0.5, 3.5};
  double* params[2] = {a, b};
  ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 6, 6> ad(new RelativePoseResidual(r));
  ceres::NumericDiffCostFunction<RelativePoseResidual, ceres::CENTRAL, 6, 6, 6> nd(new RelativePoseResidual(r));
  double ra[6], rn[6], ja0[36], ja1[36], jn0[36], jn1[36];
  double* ja[2] = {ja0, ja1};
  double* jn[2] = {jn0, jn1};
  ASSERT_TRUE(ad.Evaluate(params, ra, ja));
  ASSERT_TRUE(nd.Evaluate(params, rn, jn));
  for (int i = 0; i < 36; ++i) {
    EXPECT_NEAR(ja0[i], jn0[i], 1e-6 * (1 + std::abs(jn0[i]))) << i;
    EXPECT_NEAR(ja1[i], jn1[i], 1e-6 * (1 + std::abs(jn1[i]))) << i;
  }
}

// A pose graph whose sequential edges drifted is pulled back by one loop edge.
TEST(PoseGraph, Nominal) {
  const int n = 20;
  std::vector<Eigen::Isometry3d> truth(n), est(n);
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    truth[i] = Eigen::Isometry3d::Identity();
    truth[i].linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    truth[i].translation() = Eigen::Vector3d(10 * std::cos(a), 10 * std::sin(a), 0);
  }
  std::vector<PoseGraphEdge> edges;
  Eigen::Isometry3d drift = Eigen::Isometry3d::Identity();
  drift.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  drift.translation() = Eigen::Vector3d(0.05, 0.02, 0);
  est[0] = truth[0];
  for (int i = 1; i < n; ++i) {
    const Eigen::Isometry3d rel = truth[i - 1].inverse() * truth[i] * drift;  // biased odometry
    est[i] = est[i - 1] * rel;
    edges.push_back({i - 1, i, rel, 1.0});
  }
  edges.push_back({n - 1, 0, truth[n - 1].inverse() * truth[0], 1.0});
  const double before = (est[n - 1].translation() - truth[n - 1].translation()).norm();
  OptimizePoseGraph(&est, edges, {0}, 50);
  const double after = (est[n - 1].translation() - truth[n - 1].translation()).norm();
  EXPECT_GT(before, 0.5);
  EXPECT_LT(after, 0.1 * before);
}

// SolveSmallBundle against Ceres (DENSE_SCHUR, autodiff, same Huber losses) on one synthetic window:
// 6 poses (2 fixed), 300 points, stereo and mono observations with 0.5 px noise and 5 % gross
// outliers, from one perturbed start. Both must reach the same minimum, near the truth.
TEST(SmallBundle, MatchesCeres) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 0.5), pert(0, 1);
  std::uniform_real_distribution<double> uni(0, 1);
  const double fx = 700, fy = 700, cx = 600, cy = 185, b = 0.54;
  SmallBundleProblem truth;
  for (int k = 0; k < 6; ++k) {  // cameras moving along +z (T_cam_world: t = -0.8 k z)
    truth.poses.push_back({0.01 * k, -0.02 * k, 0.005 * k, 0.05 * k, -0.02 * k, -0.8 * k});
    truth.pose_fixed.push_back(k < 2);
  }
  for (int i = 0; i < 300; ++i)
    truth.points.push_back({(uni(rng) - 0.5) * 12, (uni(rng) - 0.5) * 3, 8 + uni(rng) * 30});
  for (int i = 0; i < 300; ++i) {
    for (int k = 0; k < 6; ++k) {
      if (uni(rng) < 0.3) continue;
      double pc[3];
      ReprojectionResidual r{0, 0, -1, fx, fy, cx, cy, b, 1.0};
      double res[3];
      EvaluateReprojection(r, truth.poses[k].data(), truth.points[i].data(), res, nullptr, nullptr);
      // res = projection - 0 with u = v = 0: the projections themselves.
      pc[0] = res[0];
      pc[1] = res[1];
      if (pc[0] < 0 || pc[0] >= 1226 || pc[1] < 0 || pc[1] >= 370) continue;  // outside a KITTI-size image
      const bool stereo = uni(rng) < 0.7;
      const bool outlier = uni(rng) < 0.05;
      SmallBundleObservation o;
      o.pose = k;
      o.point = i;
      o.r = r;
      o.r.u = pc[0] + noise(rng) + (outlier ? 30 : 0);
      o.r.v = pc[1] + noise(rng);
      if (stereo) {
        ReprojectionResidual rs_{0, 0, 0, fx, fy, cx, cy, b, 1.0};
        EvaluateReprojection(rs_, truth.poses[k].data(), truth.points[i].data(), res, nullptr, nullptr);
        o.r.u_right = std::max(0.0, res[2] + noise(rng));
      }
      o.huber = std::sqrt(stereo ? 7.815 : 5.991);
      truth.observations.push_back(o);
    }
  }
  SmallBundleProblem start = truth;
  for (int k = 2; k < 6; ++k)
    for (int d = 0; d < 6; ++d) start.poses[k][d] += (d < 3 ? 0.01 : 0.1) * pert(rng);
  for (auto& x : start.points)
    for (double& v : x) v += 0.2 * pert(rng);

  SmallBundleProblem mine = start;
  const SmallBundleSummary s = SolveSmallBundle(&mine, 50);
  SmallBundleProblem ref = start;
  ceres::Problem problem;
  ceres::LossFunction* ls = new ceres::HuberLoss(std::sqrt(7.815));
  ceres::LossFunction* lm = new ceres::HuberLoss(std::sqrt(5.991));
  for (const auto& o : ref.observations)
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<ReprojectionResidual, 3, 6, 3>(new ReprojectionResidual(o.r)),
        o.r.u_right >= 0 ? ls : lm, ref.poses[o.pose].data(), ref.points[o.point].data());
  for (int k = 0; k < 2; ++k) problem.SetParameterBlockConstant(ref.poses[k].data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = 50;
  options.function_tolerance = 1e-12;
  options.num_threads = 1;
  ceres::Solver::Summary cs;
  ceres::Solve(options, &problem, &cs);

  EXPECT_GT(s.initial_cost, 10 * s.final_cost);
  EXPECT_NEAR(s.initial_cost, cs.initial_cost, 1e-9 * cs.initial_cost);
  EXPECT_NEAR(s.final_cost, cs.final_cost, 1e-4 * cs.final_cost);  // same minimum (Ceres ran to 1e-12)
  for (int k = 0; k < 6; ++k)
    for (int d = 0; d < 6; ++d) {
      EXPECT_NEAR(mine.poses[k][d], ref.poses[k][d], d < 3 ? 1e-5 : 1e-4) << k << " " << d;
      EXPECT_NEAR(mine.poses[k][d], truth.poses[k][d], d < 3 ? 2e-3 : 5e-2)
          << k << " " << d;  // 0.1 deg, 5 cm (0.5 px noise)
    }
  for (int k = 0; k < 2; ++k) EXPECT_EQ(mine.poses[k], start.poses[k]);  // fixed means fixed
}

}  // namespace
}  // namespace rs
