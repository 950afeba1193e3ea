#include "stages/disparity/road_model.h"

#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "sim/synthetic_road_pair.h"

namespace rs {
namespace {

std::vector<DisparitySample> PlaneSamples(double a0, double a1, double phi, int n, double outlier_share,
                                          unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1280), V(0, 720), O(-20, 20);
  std::normal_distribution<double> noise(0, 0.2);
  std::vector<DisparitySample> s;
  for (int i = 0; i < n; ++i) {
    const double u = U(rng), v = V(rng);
    double d = a0 + a1 * (v * std::cos(phi) - u * std::sin(phi)) + noise(rng);
    if (i < outlier_share * n) d += O(rng) + (O(rng) > 0 ? 5 : -5);
    s.push_back({u, v, d});
  }
  return s;
}

TEST(RoadModel, Nominal) {
  const double a0 = 25, a1 = 0.06, phi = 0.12;
  const auto s = PlaneSamples(a0, a1, phi, 600, 0.3, 3);
  RoadFitOptions o;
  const RoadModel m = FitRoadModel(s, 1280, 720, o);
  EXPECT_TRUE(m.reliable);
  EXPECT_NEAR(m.a0, a0, 0.1);
  EXPECT_NEAR(m.a1, a1, 1e-3);
  EXPECT_NEAR(m.roll_rad, phi, 5e-3);
  EXPECT_NEAR(m.num_inliers, 420, 15);  // 70 % clean samples
  EXPECT_NEAR(m.residual_rms_px, 0.2, 0.05);
  EXPECT_NEAR(m.At(100, 600), a0 + a1 * (600 * std::cos(phi) - 100 * std::sin(phi)), 0.05);
}

TEST(RoadModel, ClosedFormEqualsPlaneFit) {
  const auto s = PlaneSamples(40, -0.05, -0.3, 300, 0.0, 5);
  const RoadModel cf = FitRoadModelClosedForm(s);
  RoadFitOptions o;
  o.inlier_threshold_px = 100;  // every sample an inlier: plain least squares
  const RoadModel ls = FitRoadModel(s, 1280, 720, o);
  EXPECT_NEAR(cf.a0, ls.a0, 1e-6);
  EXPECT_NEAR(cf.a1, ls.a1, 1e-9);
  EXPECT_NEAR(cf.roll_rad, ls.roll_rad, 1e-7);
  EXPECT_NEAR(cf.roll_rad, -0.3, 0.01);
  EXPECT_NEAR(cf.a1, -0.05, 1e-3);
}

TEST(RoadModel, QuadraticCamber) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> U(0, 1000), V(0, 600);
  std::vector<DisparitySample> s;
  auto truth = [](double u, double v) { return 20 + 0.05 * v - 0.002 * u + 2e-5 * (u - 500) * (u - 500); };
  for (int i = 0; i < 500; ++i) {
    const double u = U(rng), v = V(rng);
    s.push_back({u, v, truth(u, v)});
  }
  RoadFitOptions o;
  o.quadratic = true;
  o.inlier_threshold_px = 3.0;  // the plane must catch most points first (camber up to 5 px)
  const RoadModel m = FitRoadModel(s, 1000, 600, o);
  ASSERT_TRUE(m.quadratic);
  EXPECT_LT(m.residual_rms_px, 0.01);
  EXPECT_NEAR(m.At(500, 300), truth(500, 300), 0.01);
  EXPECT_NEAR(m.RowMin(300, 1000), truth(550, 300), 0.01);  // interior vertex at u = 550
}

TEST(RoadModel, TooFewMatchesIsUnreliable) {
  const auto s = PlaneSamples(25, 0.06, 0.0, 12, 0.0, 4);
  const RoadModel m = FitRoadModel(s, 1280, 720, RoadFitOptions{});
  EXPECT_FALSE(m.reliable);  // 12 < min_inliers: the high-altitude case
  EXPECT_EQ(m.num_inliers, 12);
}

TEST(RoadModel, NotARoadIsUnreliable) {
  // 40 % on a plane, 60 % scattered (a non-road scene): enough inliers, too small a share.
  auto s = PlaneSamples(25, 0.06, 0.0, 400, 0.6, 8);
  const RoadModel m = FitRoadModel(s, 1280, 720, RoadFitOptions{});
  EXPECT_GE(m.num_inliers, 150);
  EXPECT_FALSE(m.reliable);
}

TEST(RoadModel, PriorSeedsFit) {
  RoadModel prior;
  prior.SetRoll(25, 0.06, 0.1);
  // Half the samples are outliers spread on a competing plane; the prior picks the road.
  auto s = PlaneSamples(25, 0.06, 0.1, 200, 0.0, 6);
  const auto other = PlaneSamples(60, 0.0, 0.0, 150, 0.0, 7);
  s.insert(s.end(), other.begin(), other.end());
  RoadFitOptions o;
  o.ransac_iterations = 1;
  o.min_inlier_fraction = 0.4;
  const RoadModel m = FitRoadModel(s, 1280, 720, o, &prior);
  EXPECT_TRUE(m.reliable);
  EXPECT_NEAR(m.a0, 25, 0.2);
  EXPECT_EQ(FitRoadModel({}, 1280, 720, o, &prior).from_prior, true);
}

TEST(RoadModel, SparseMatchesOnSyntheticRoad) {
  SyntheticRoadOptions so;
  so.width = 640, so.height = 360, so.c0 = 20, so.cu = -0.01, so.cv = 0.05, so.pothole_u = 300, so.pothole_v = 250,
  so.pothole_radius_px = 40;
  const auto pair = MakeSyntheticRoadPair(so);
  const auto samples = MatchSparseDisparities(pair.left, pair.right, RoadFitOptions{});
  ASSERT_GT(samples.size(), 200u);
  int good = 0;
  for (const auto& s : samples) good += std::abs(s.d - pair.gt.at<float>(cvRound(s.v), cvRound(s.u))) < 0.5;
  EXPECT_GT(good, 0.9 * samples.size());
  const RoadModel m = FitRoadModel(samples, 640, 360, RoadFitOptions{});
  ASSERT_TRUE(m.reliable);
  EXPECT_NEAR(m.At(0, 0), 20, 0.3);
  EXPECT_NEAR(m.At(600, 300), 20 - 6 + 15, 0.3);
}

TEST(RoadModel, BadOptions) {
  RoadFitOptions o;
  o.ratio = 1.5;
  EXPECT_THROW(o.Check(), std::invalid_argument);
  o = RoadFitOptions{};
  o.min_inliers = 2;
  EXPECT_THROW(FitRoadModel({}, 10, 10, o), std::invalid_argument);
}

// A camera pitched down by alpha on a platform rolled by rho about its horizontal forward axis sees
// the road plane with normal n = (sin rho, ...) in camera axes: the lateral tilt is rho at every
// pitch, while the roll phi of the image gradient grows to 90 deg towards a nadir view.
TEST(RoadModel, LateralTiltIsThePlatformRoll) {
  const double f = 1000, cx = 640, cy = 360, B = 0.2, h = 10;
  for (const double alpha_deg : {5.0, 30.0, 60.0, 89.0})
    for (const double rho_deg : {-20.0, 0.0, 3.0, 40.0}) {
      const double a = alpha_deg * M_PI / 180, rho = rho_deg * M_PI / 180;
      // Camera axes in the world (x east, y forward, z up) before the roll, then rolled about y.
      const Eigen::Matrix3d roll = Eigen::AngleAxisd(rho, Eigen::Vector3d::UnitY()).toRotationMatrix();
      const Eigen::Vector3d xc = roll * Eigen::Vector3d(1, 0, 0),
                            yc = roll * Eigen::Vector3d(0, -std::sin(a), -std::cos(a)),
                            zc = roll * Eigen::Vector3d(0, std::cos(a), -std::sin(a));
      const Eigen::Vector3d down(0, 0, -1);
      const double nx = xc.dot(down), ny = yc.dot(down), nz = zc.dot(down);  // road normal, camera axes
      // d = (B/h) n . (u - cx, v - cy, f)
      RoadModel m;
      m.SetPlane(B / h * (nz * f - nx * cx - ny * cy), B / h * nx, B / h * ny);
      EXPECT_NEAR(std::abs(RoadLateralTiltRad(m, f, cx, cy)) * 180 / M_PI, std::abs(rho_deg), 1e-6)
          << "alpha " << alpha_deg << " rho " << rho_deg;
      if (rho_deg != 0)  // signed like the roll phi
        EXPECT_EQ(RoadLateralTiltRad(m, f, cx, cy) > 0, m.roll_rad > 0) << "alpha " << alpha_deg << " rho " << rho_deg << " phi " << m.roll_rad * 180 / M_PI;
      if (alpha_deg == 5.0) EXPECT_NEAR(std::abs(m.roll_rad) * 180 / M_PI, std::abs(rho_deg), 0.2);
    }
}

TEST(RoadModel, DisparityRangeOfMatches) {
  std::vector<DisparitySample> s;
  for (int i = 0; i <= 100; ++i) s.push_back({double(i), 0.0, 200.0 + i});  // 200..300 px
  s.push_back({0, 0, 1500});  // an outlier beyond the 99th percentile
  const DisparityRange r = DisparityRangeOfMatches(s, 2000, 8, 40);
  // 1st..99th percentile 201..300, widened by 0.1 * 99 + 8 = 17.9 px: [183, 319).
  EXPECT_EQ(r.min, 183);
  EXPECT_EQ(r.min + r.num, 319);
  EXPECT_EQ(DisparityRangeOfMatches(s, 2000, 8, 200).num, 0);  // too few matches
  const DisparityRange clamped = DisparityRangeOfMatches(s, 250, 8, 40);  // the image is narrower
  EXPECT_EQ(clamped.min + clamped.num, 250);
}

}  // namespace
}  // namespace rs
