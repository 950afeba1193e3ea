#include "formats/flight_log/kitti_oxts.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <GeographicLib/LocalCartesian.hpp>
#include <cmath>
#include <fstream>
#include <sstream>

#include "formats/flight_log/sample_mutation.h"
#include "formats/input_error.h"

namespace rs {
namespace {

constexpr const char* kRecord0 =
    "49.032806841152 8.4385595703734 113.9702835083 0.010009 0.007367 2.9196693267949 2.0015688190113 -8.5106218673827 "
    "8.7424908583432 0.076390461431484 -0.10478895840789 0.35440792081468 0.23382035769103 9.8901658673859 "
    "0.428539476993 "
    "0.13258431756988 9.8890929132653 -0.0037897649679662 -0.0026699472128077 0.0061605421983224 -0.0037445712537476 "
    "-0.0027321086947683 0.0061607573413927 0.17055204484262 0.027586228448267 4 6 5 5 0\n";

TEST(KittiOxts, Nominal) {
  std::istringstream in(kRecord0);
  FlightTrack t;
  ReadKittiOxtsRecord(in, "0.txt", 42, &t);
  ASSERT_EQ(t.fixes.size(), 1u);
  const GnssFix& f = t.fixes[0];
  EXPECT_EQ(f.t_ns, 42);
  EXPECT_DOUBLE_EQ(f.lat_deg, 49.032806841152);
  EXPECT_DOUBLE_EQ(f.lon_deg, 8.4385595703734);
  EXPECT_DOUBLE_EQ(f.alt_m, 113.9702835083);
  EXPECT_EQ(f.alt_ref, AltitudeReference::kAmsl);
  EXPECT_EQ(f.satellites, 6);
  EXPECT_EQ(f.fix_type, 5);  // posmode 5: RTK float
  EXPECT_DOUBLE_EQ(f.h_acc_m, 0.17055204484262);
  EXPECT_NEAR(f.ground_speed_m_s, std::hypot(2.0015688190113, -8.5106218673827), 1e-12);
  // Attitude: the quaternion must equal R_ned_enu * R_enu_flu(KITTI devkit: Rz(yaw) Ry(pitch) Rx(roll)) * R_flu_frd.
  ASSERT_EQ(t.attitude.size(), 1u);
  const double roll = 0.010009, pitch = 0.007367, yaw = 2.9196693267949;
  const Eigen::Matrix3d R_enu_flu =
      (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  Eigen::Matrix3d R_ned_enu;
  R_ned_enu << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  const Eigen::Matrix3d R_flu_frd = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Eigen::Matrix3d truth = R_ned_enu * R_enu_flu * R_flu_frd;
  const AttitudeSample& a = t.attitude[0];
  const Eigen::Matrix3d got = Eigen::Quaterniond(a.qw, a.qx, a.qy, a.qz).toRotationMatrix();
  EXPECT_LT((got - truth).norm(), 1e-12);
}

TEST(KittiOxts, TooFewValues) {
  std::istringstream in("49.0 8.4 113.9\n");
  FlightTrack t;
  try {
    ReadKittiOxtsRecord(in, "0.txt", 0, &t);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 1);
    EXPECT_NE(e.message().find("expected 30 values, got 3"), std::string::npos);
  }
}

TEST(KittiOxts, BadValue) {
  std::string rec = kRecord0;
  rec.replace(rec.find("113.97"), 1, "x");
  std::istringstream in(rec);
  FlightTrack t;
  try {
    ReadKittiOxtsRecord(in, "0.txt", 0, &t);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 1);
    EXPECT_EQ(e.where().column, 33);
    EXPECT_NE(e.message().find("value 3 is not a number"), std::string::npos);
  }
}

TEST(KittiOxts, BadTimestamp) {
  std::istringstream in("2011-09-26 13:17:59.293761040\n2011-09-26 13:17:5x.393600894\n");
  try {
    ReadKittiTimestamps(in, "timestamps.txt");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
  }
}

TEST(KittiOxts, MissingFolder) { EXPECT_THROW(ReadKittiOxts("/nonexistent/oxts"), InputError); }

std::filesystem::path DriveDir() {
  return testing::DataRoot() / "kitti_raw_tiny" / "KITTI_tiny" / "2011_09_26" / "2011_09_26_drive_0023_sync";
}

// The OXTS positions in a local metric frame must match the camera poses TRI
// derived from the same drive (image_02/poses.txt) up to a rigid transform.
TEST(KittiOxtsSample, ConsistentWithShippedPoses) {
  if (!std::filesystem::is_directory(DriveDir())) GTEST_SKIP() << "no " << DriveDir() << " (set ROADSURVEY_DATA)";
  const FlightTrack t = ReadKittiOxts(DriveDir() / "oxts");
  ASSERT_EQ(t.fixes.size(), 7u);
  ASSERT_EQ(t.attitude.size(), 7u);
  EXPECT_EQ(t.time_base, TimeBase::kUtc);
  EXPECT_EQ(t.fixes[0].t_ns, 1317043079293761040LL);  // 2011-09-26 13:17:59.293761040 (line 1)
  EXPECT_EQ(t.fixes[6].t_ns, 1317043079913621630LL);  // line 7

  std::ifstream poses(DriveDir() / "image_02" / "poses.txt");
  ASSERT_TRUE(poses.good());
  const GeographicLib::LocalCartesian enu(t.fixes[0].lat_deg, t.fixes[0].lon_deg, t.fixes[0].alt_m);
  Eigen::Matrix<double, 3, Eigen::Dynamic> p_enu(3, 7), p_cam(3, 7);
  for (int i = 0; i < 7; ++i) {
    double T[12];
    for (double& v : T) ASSERT_TRUE(static_cast<bool>(poses >> v));
    p_cam.col(i) << T[3], T[7], T[11];
    double x, y, z;
    enu.Forward(t.fixes[i].lat_deg, t.fixes[i].lon_deg, t.fixes[i].alt_m, x, y, z);
    p_enu.col(i) << x, y, z;
  }
  // Least-squares alignment (Umeyama). poses.txt turns out NOT to be metric
  // relative to OXTS: a rigid fit leaves ~0.86 m RMS on this 5.6 m path, a
  // similarity fit ~0.03 m at scale ~0.54 (TRI's derivation; see the docs). So
  // the shape is checked with a similarity fit, the metric scale separately
  // against the OXTS's own velocity below.
  const Eigen::Matrix4d T_cam_enu = Eigen::umeyama(p_enu, p_cam, true);
  const double scale = std::cbrt(T_cam_enu.topLeftCorner<3, 3>().determinant());
  double sum2 = 0;
  for (int i = 0; i < 7; ++i)
    sum2 += ((T_cam_enu.topLeftCorner<3, 3>() * p_enu.col(i) + T_cam_enu.topRightCorner<3, 1>()) - p_cam.col(i))
                .squaredNorm();
  const double rms_m = std::sqrt(sum2 / 7);
  double path_m = 0;
  for (int i = 1; i < 7; ++i) path_m += (p_enu.col(i) - p_enu.col(i - 1)).norm();
  std::cout << "OXTS vs poses.txt: path " << path_m << " m, similarity scale " << scale << ", residual RMS " << rms_m
            << " m\n";
  EXPECT_GT(path_m, 2.0);  // the car moved: the check is not trivially satisfied
  EXPECT_LT(rms_m, 0.1);   // measured 0.031 m (sub-metre required)
  EXPECT_GT(scale, 0.5);   // measured 0.539: documents the data's scale, fails if the data changes
  EXPECT_LT(scale, 0.58);

  // Metric truth from the OXTS itself: path length vs speed (vn, ve) integrated over timestamps.txt.
  double speed_path_m = 0;
  for (int i = 1; i < 7; ++i)
    speed_path_m += 0.5 * (t.fixes[i].ground_speed_m_s + t.fixes[i - 1].ground_speed_m_s) *
                    (t.fixes[i].t_ns - t.fixes[i - 1].t_ns) * 1e-9;
  std::cout << "OXTS path from positions " << path_m << " m, from speed x time " << speed_path_m << " m\n";
  EXPECT_NEAR(path_m / speed_path_m, 1.0, 0.05);  // measured ~1.025 (the synced packets jitter by ~10 ms)

  // Attitude on real data: the converted yaw (NED, from north clockwise) must point along the motion.
  for (int i = 1; i < 7; ++i) {
    const Eigen::Vector3d d = p_enu.col(i) - p_enu.col(i - 1);
    const double heading_motion = std::atan2(d.x(), d.y());  // east, north
    const AttitudeSample& a = t.attitude[i];
    const double yaw = std::atan2(2 * (a.qw * a.qz + a.qx * a.qy), 1 - 2 * (a.qy * a.qy + a.qz * a.qz));
    EXPECT_NEAR(std::remainder(yaw - heading_motion, 2 * M_PI), 0.0, 3.0 * M_PI / 180) << i;
  }
}

TEST(KittiOxtsSample, TruncatedAndBitFlippedCopies) {
  if (!std::filesystem::is_directory(DriveDir())) GTEST_SKIP() << "no " << DriveDir() << " (set ROADSURVEY_DATA)";
  const std::string rec = testing::Slurp(DriveDir() / "oxts" / "data" / "0000000003.txt");
  const auto st = testing::Mutate(
      rec,
      [](std::istream& in) {
        FlightTrack t;
        ReadKittiOxtsRecord(in, "r.txt", 0, &t);
        return t;
      },
      30, 200, 5);
  EXPECT_GT(st.input_errors, 30);
  EXPECT_EQ(st.input_errors_with_line, st.input_errors);
  const std::string ts = testing::Slurp(DriveDir() / "oxts" / "timestamps.txt");
  int errors = 0;
  for (int i = 0; i < 200; ++i) {
    std::string s = ts;
    s[(i * 7919) % s.size()] ^= static_cast<char>(1 << (i % 8));
    std::istringstream in(s);
    try {
      ReadKittiTimestamps(in, "timestamps.txt");
    } catch (const InputError& e) {
      ++errors;
      EXPECT_GE(e.where().line, 1);
    }
  }
  EXPECT_GT(errors, 50);
}

}  // namespace
}  // namespace rs
