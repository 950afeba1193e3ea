#include "stages/georeference/georeference.h"

#include <gtest/gtest.h>

#include <random>

namespace rs {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A straight (or gently curved) drive in ENU, a nadir camera, and the same drive seen from an
// arbitrary SLAM world: T_slam_enu applied to every pose. Road points on a cambered road.
struct Scene {
  std::vector<GeoFrame> frames;
  std::vector<Eigen::Isometry3d> T_enu_cam;  // truth
  std::vector<Eigen::Vector3d> road_slam;
  RigGeometry rig;
  Eigen::Isometry3d T_slam_enu;
};

Scene MakeScene(double curvature, double gnss_sigma_m, double attitude_sigma_deg, bool attitude, uint64_t seed,
                const Eigen::Vector3d& lever_arm_body_m = Eigen::Vector3d::Zero()) {
  Scene s;
  s.rig.lever_arm_body_m = lever_arm_body_m;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  // Nadir camera: x = body right, y = -body forward, z = body down.
  s.rig.R_body_cam.col(0) = Eigen::Vector3d(0, 1, 0);
  s.rig.R_body_cam.col(1) = Eigen::Vector3d(-1, 0, 0);
  s.rig.R_body_cam.col(2) = Eigen::Vector3d(0, 0, 1);
  s.T_slam_enu = Eigen::Isometry3d::Identity();
  s.T_slam_enu.linear() = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  s.T_slam_enu.translation() = Eigen::Vector3d(5, -3, 2);
  const double heading = 30 * kDeg;  // compass bearing
  for (int i = 0; i < 60; ++i) {
    const double along = 0.4 * i;
    const double yaw_enu = M_PI / 2 - heading + curvature * along;
    Eigen::Vector3d p(along * std::cos(M_PI / 2 - heading), along * std::sin(M_PI / 2 - heading), 6.0 + 0.02 * along);
    p += Eigen::Vector3d(-std::sin(M_PI / 2 - heading), std::cos(M_PI / 2 - heading), 0) * (0.5 * curvature * along * along);
    // Body FRD -> NED from yaw (compass), pitch, roll with a small wobble.
    const double yaw_ned = M_PI / 2 - yaw_enu, pitch = 1.0 * kDeg * std::sin(0.3 * i), roll = 1.5 * kDeg * std::cos(0.2 * i);
    const Eigen::Matrix3d R_ned_body = (Eigen::AngleAxisd(yaw_ned, Eigen::Vector3d::UnitZ()) *
                                        Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                                        Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX())).toRotationMatrix();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = RotationEnuNed() * R_ned_body * s.rig.R_body_cam;
    T.translation() = p;
    s.T_enu_cam.push_back(T);
    GeoFrame f;
    f.frame = i;
    f.t_ns = 1000000000LL + i * 100000000LL;
    f.T_slam_cam = s.T_slam_enu * T;
    const Eigen::Vector3d antenna = p + RotationEnuNed() * R_ned_body * lever_arm_body_m;
    f.gnss_enu = antenna + gnss_sigma_m * Eigen::Vector3d(n01(rng), n01(rng), 1.5 * n01(rng));
    if (attitude) {
      const Eigen::Vector3d e = attitude_sigma_deg * kDeg * Eigen::Vector3d(n01(rng), n01(rng), n01(rng));
      f.R_ned_body = R_ned_body * Eigen::AngleAxisd(e.norm(), e.normalized()).toRotationMatrix();
    }
    s.frames.push_back(f);
    // Road under the camera: 7 m wide, crown in the middle, 2.5 % crossfall, 4 cm texture noise.
    const Eigen::Vector3d left(-std::sin(yaw_enu), std::cos(yaw_enu), 0);
    for (int k = 0; k < 40; ++k) {
      const double lat = -3.5 + 7.0 * (k + 0.5) / 40.0 + 0.05 * n01(rng);
      Eigen::Vector3d q = p + left * lat + Eigen::Vector3d(std::cos(yaw_enu), std::sin(yaw_enu), 0) * (0.4 * n01(rng));
      q.z() = 0.02 * along - 0.025 * std::abs(lat) + 0.01 * n01(rng);
      s.road_slam.push_back(s.T_slam_enu * q);
    }
  }
  return s;
}

double RollErrorDeg(const GeoreferenceResult& r, const Scene& s) {
  double worst = 0;
  for (size_t i = 0; i < s.frames.size(); ++i) {
    const Eigen::Matrix3d R_true = RotationEnuNed() * s.T_enu_cam[i].linear() * s.rig.R_body_cam.transpose();
    const Eigen::Vector3d d = YawPitchRollDeg(*r.cameras[i].R_ned_body) - YawPitchRollDeg(R_true);
    worst = std::max(worst, std::abs(d.z()));
  }
  return worst;
}

double CentreRmse(const GeoreferenceResult& r, const Scene& s) {
  double ss = 0;
  for (size_t i = 0; i < s.frames.size(); ++i) ss += (r.cameras[i].p_enu - s.T_enu_cam[i].translation()).squaredNorm();
  return std::sqrt(ss / s.frames.size());
}

TEST(Georeference, Nominal) {
  const Scene s = MakeScene(0.01, 0.01, 0.3, true, 1);
  GeoreferenceOptions o;
  o.fit.sigma_m = 0.02;
  const auto r = Georeference(s.frames, s.road_slam, s.rig, o);
  EXPECT_EQ(r.roll_method, RollSource::kAttitude);
  EXPECT_LT(CentreRmse(r, s), 0.01);
  EXPECT_LT(RollErrorDeg(r, s), 0.1);
  EXPECT_EQ(r.cameras[3].status, CameraStatus::kVisual);
}

TEST(Georeference, StraightTrackRollFromAttitude) {
  const Scene s = MakeScene(0.0, 0.3, 0.3, true, 2);
  GeoreferenceOptions o;
  o.fit.sigma_m = 0.3;
  // Positions alone leave the roll anywhere.
  o.roll_source = RollSource::kPositions;
  const auto loose = Georeference(s.frames, s.road_slam, s.rig, o);
  o.roll_source = RollSource::kAuto;
  const auto r = Georeference(s.frames, s.road_slam, s.rig, o);
  EXPECT_EQ(r.roll_method, RollSource::kAttitude);
  EXPECT_GT(r.roll.weight, 0.95);
  EXPECT_LT(RollErrorDeg(r, s), 0.2);
  EXPECT_GT(RollErrorDeg(loose, s), RollErrorDeg(r, s));
}

TEST(Georeference, StraightTrackRollFromRoadPlane) {
  const Scene s = MakeScene(0.0, 0.3, 0.3, false, 3);
  GeoreferenceOptions o;
  o.fit.sigma_m = 0.3;
  const auto r = Georeference(s.frames, s.road_slam, s.rig, o);
  EXPECT_EQ(r.roll_method, RollSource::kRoadPlane);
  EXPECT_GE(r.road_planes, 2);
  // Camera roll = platform wobble (up to 1.5 deg) + road-plane error: the planes are level
  // within the camber's asymmetry; the wobble is in the truth, so this is the road's error alone.
  EXPECT_LT(RollErrorDeg(r, s), 0.5);
}

TEST(Georeference, OutlierFixesAreRejected) {
  Scene s = MakeScene(0.01, 0.02, 0.3, true, 4);
  for (int i : {5, 17, 40}) *s.frames[i].gnss_enu += Eigen::Vector3d(8, -6, 3);
  GeoreferenceOptions o;
  o.fit.sigma_m = 0.05;
  const auto r = Georeference(s.frames, s.road_slam, s.rig, o);
  int outliers = 0;
  for (const auto& res : r.residuals) outliers += !res.inlier;
  EXPECT_EQ(outliers, 3);
  EXPECT_FALSE(r.residuals[17].inlier);
  EXPECT_LT(CentreRmse(r, s), 0.02);
}

TEST(Georeference, Sim3EstimatesScaleWithSigma) {
  Scene s = MakeScene(0.01, 0.05, 0.3, true, 5);
  for (auto& f : s.frames) f.T_slam_cam->translation() *= 0.8;  // SLAM at 0.8 x metric
  GeoreferenceOptions o;
  o.fit.sigma_m = 0.05;
  o.fit.estimate_scale = true;
  const auto r = Georeference(s.frames, s.road_slam, s.rig, o);
  EXPECT_NEAR(r.fit.transform.scale, 1.25, 4 * r.fit.scale_sigma + 1e-4);
  EXPECT_GT(r.fit.scale_sigma, 0.0);
  EXPECT_LT(r.fit.scale_sigma, 0.005);
}

TEST(Georeference, FramesWithoutPoseAreGnssOnlyOrSkipped) {
  Scene s = MakeScene(0.01, 0.02, 0.3, true, 6);
  s.frames[10].T_slam_cam.reset();
  s.frames[11].T_slam_cam.reset();
  s.frames[11].gnss_enu.reset();
  GeoreferenceOptions o;
  o.fit.sigma_m = 0.05;
  const auto r = Georeference(s.frames, s.road_slam, s.rig, o);
  EXPECT_EQ(r.cameras[10].status, CameraStatus::kGnssOnly);
  EXPECT_NEAR((r.cameras[10].p_enu - s.T_enu_cam[10].translation()).norm(), 0.0, 0.1);
  EXPECT_EQ(r.cameras[11].status, CameraStatus::kSkipped);
}

TEST(Georeference, LeverArmIsTakenOffTheFix) {
  const Eigen::Vector3d lever(0.6, -0.3, -1.2);  // antenna ahead, left of and above the camera
  const Scene s = MakeScene(0.03, 0.01, 0.3, true, 8, lever);
  GeoreferenceOptions o;
  o.fit.sigma_m = 0.02;
  EXPECT_LT(CentreRmse(Georeference(s.frames, s.road_slam, s.rig, o), s), 0.01);
  RigGeometry no_lever = s.rig;
  no_lever.lever_arm_body_m.setZero();
  EXPECT_GT(CentreRmse(Georeference(s.frames, s.road_slam, no_lever, o), s), 0.5) << "ignoring it costs its length";
}

TEST(Georeference, TooFewFixesThrows) {
  Scene s = MakeScene(0.01, 0.02, 0.3, true, 7);
  for (size_t i = 2; i < s.frames.size(); ++i) s.frames[i].gnss_enu.reset();
  EXPECT_THROW(Georeference(s.frames, s.road_slam, s.rig, GeoreferenceOptions()), std::invalid_argument);
}

}  // namespace
}  // namespace rs
