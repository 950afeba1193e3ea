#include <cmath>
#include "tests/support/test_data.h"
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "formats/input_error.h"
#include "formats/trajectory/euroc_trajectory.h"
#include "formats/trajectory/kitti_poses.h"
#include "formats/trajectory/trajectory_file.h"
#include "formats/trajectory/tum_trajectory.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

fs::path EvoData() { return rs::test::DataRoot() / "kitti_euroc_trajectories" / "evo" / "test" / "data"; }

#define SKIP_WITHOUT_EVO_DATA() \
  if (!fs::exists(EvoData()))   \
  GTEST_SKIP() << "real trajectories not found at " << EvoData() << " (set ROADSURVEY_DATA to the shared data folder)"

/// Runs `read` on `text` and returns the InputError's location; fails the test if nothing is thrown.
template <typename Read>
InputLocation ErrorAt(const std::string& text, Read read, std::string* message = nullptr) {
  std::istringstream in(text);
  try {
    read(in);
  } catch (const InputError& e) {
    if (message) *message = e.message();
    return e.where();
  }
  ADD_FAILURE() << "no InputError for:\n" << text;
  return {};
}

auto ReadTum = [](std::istream& in) { return ReadTumTrajectory(in, "est.tum"); };
auto ReadEuroc = [](std::istream& in) { return ReadEurocTrajectory(in, "gt.csv"); };
auto ReadKitti = [](std::istream& in) { return ReadKittiPoses(in, "00.txt"); };
auto ReadTimes = [](std::istream& in) { return ReadKittiTimes(in, "times.txt"); };

TEST(TumTrajectory, Nominal) {
  std::istringstream in(
      "# comment\n"
      "\n"
      "1403715529.112143517 1 2 3 0 0 0 1\r\n"
      "1403715529.212142944\t-0.5 0.25 1e-3 0 0 0.7071067811865476 0.7071067811865476\n"
      "1403715529.212142944,0,0,0,0,0,0,1\n");  // repeated time (real SLAM output does this)
  const Trajectory t = ReadTumTrajectory(in, "est.tum");
  ASSERT_EQ(t.poses.size(), 3u);
  EXPECT_TRUE(t.has_times);
  EXPECT_EQ(t.source, "est.tum");
  EXPECT_EQ(t.poses[0].t_ns, INT64_C(1403715529112143517));
  EXPECT_EQ(t.poses[1].t_ns, INT64_C(1403715529212142944));
  EXPECT_TRUE(t.poses[0].T_world_frame.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  // 90 degrees about z: x axis maps to y.
  EXPECT_TRUE((t.poses[1].T_world_frame.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_NEAR(t.poses[1].T_world_frame.translation().z(), 1e-3, 1e-15);
}

TEST(TumTrajectory, NearUnitQuaternionNormalised) {
  std::istringstream in("1 0 0 0 0 0 0 1.0009\n");
  const Trajectory t = ReadTumTrajectory(in, "est.tum");
  EXPECT_TRUE(t.poses[0].T_world_frame.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-15));
}

TEST(TumTrajectory, Malformed) {
  std::string msg;
  InputLocation at = ErrorAt("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n", ReadTum, &msg);
  EXPECT_EQ(at.path, "est.tum");
  EXPECT_EQ(at.line, 2);
  EXPECT_NE(msg.find("expected 8 fields"), std::string::npos) << msg;

  at = ErrorAt("1 0 0 0 0 0 0 1 9\n", ReadTum);
  EXPECT_EQ(at.column, 17);  // the extra field

  at = ErrorAt("1 0 0 abc 0 0 0 1\n", ReadTum, &msg);
  EXPECT_EQ(at.line, 1);
  EXPECT_EQ(at.column, 7);
  EXPECT_NE(msg.find("not a number"), std::string::npos) << msg;

  at = ErrorAt("1 0 nan 0 0 0 0 1\n", ReadTum, &msg);
  EXPECT_EQ(at.column, 5);
  EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;
  at = ErrorAt("1 0 0 0 0 0 0 inf\n", ReadTum, &msg);
  EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;
  at = ErrorAt("1 0 0 1e400 0 0 0 1\n", ReadTum, &msg);
  EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;

  at = ErrorAt("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 0.99\n", ReadTum, &msg);  // |q| - 1 = -0.01
  EXPECT_EQ(at.line, 2);
  EXPECT_EQ(at.column, 9);  // qx
  EXPECT_NE(msg.find("quaternion norm"), std::string::npos) << msg;
  ErrorAt("1 0 0 0 0 0 0 0\n", ReadTum);  // zero quaternion

  at = ErrorAt("2 0 0 0 0 0 0 1\n1.999999999 0 0 0 0 0 0 1\n", ReadTum, &msg);  // going back
  EXPECT_EQ(at.line, 2);
  EXPECT_EQ(at.column, 1);
  EXPECT_NE(msg.find("before the previous"), std::string::npos) << msg;
  ErrorAt("1x 0 0 0 0 0 0 1\n", ReadTum, &msg);
  EXPECT_NE(msg.find("decimal number of seconds"), std::string::npos) << msg;
  ErrorAt("1e11 0 0 0 0 0 0 1\n", ReadTum, &msg);
  EXPECT_NE(msg.find("does not fit"), std::string::npos) << msg;
  ErrorAt(std::string(100000, '1') + "\n", ReadTum, &msg);
  EXPECT_NE(msg.find("longer than"), std::string::npos) << msg;
}

TEST(EurocTrajectory, Nominal) {
  std::istringstream in(
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n"
      "1403715524907143168,0.515356,1.996773,0.971104,0.161996,0.789985,-0.205376,0.554528,-0.002276\n"
      "1403715524912143104, 0.5, 2, 1, 1, 0, 0, 0\n");
  const Trajectory t = ReadEurocTrajectory(in, "gt.csv");
  ASSERT_EQ(t.poses.size(), 2u);
  EXPECT_EQ(t.poses[0].t_ns, INT64_C(1403715524907143168));
  const Eigen::Quaterniond q(t.poses[0].T_world_frame.linear());
  // w first in the file; the row's quaternion has |q| = 1 - 2e-7, kept up to normalisation.
  const Eigen::Vector4d expected = Eigen::Vector4d(0.161996, 0.789985, -0.205376, 0.554528).normalized();
  EXPECT_NEAR(std::abs(q.w()), expected[0], 1e-12);
  EXPECT_NEAR(q.x() * (q.w() < 0 ? -1 : 1), expected[1], 1e-12);
  EXPECT_TRUE(t.poses[0].T_world_frame.translation().isApprox(Eigen::Vector3d(0.515356, 1.996773, 0.971104)));
  EXPECT_TRUE(t.poses[1].T_world_frame.linear().isIdentity(1e-15));
}

TEST(EurocTrajectory, Malformed) {
  std::string msg;
  InputLocation at = ErrorAt("#h\n1,0,0,0,1,0,0\n", ReadEuroc, &msg);
  EXPECT_EQ(at.line, 2);
  EXPECT_NE(msg.find("at least 8"), std::string::npos) << msg;
  at = ErrorAt("1.5,0,0,0,1,0,0,0\n", ReadEuroc, &msg);  // ns must be an integer
  EXPECT_EQ(at.column, 1);
  EXPECT_NE(msg.find("integer number of nanoseconds"), std::string::npos) << msg;
  at = ErrorAt("1,0,,0,1,0,0,0\n", ReadEuroc, &msg);  // empty cell
  EXPECT_EQ(at.column, 5);
  at = ErrorAt("1,0,0,0,1,0,0,0\n2,0,0,0,NaN,0,0,0\n", ReadEuroc, &msg);
  EXPECT_EQ(at.line, 2);
  EXPECT_EQ(at.column, 9);
  EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;
  at = ErrorAt("1,0,0,0,1.1,0,0,0\n", ReadEuroc, &msg);
  EXPECT_EQ(at.column, 9);
  EXPECT_NE(msg.find("quaternion"), std::string::npos) << msg;
  ErrorAt("99999999999999999999,0,0,0,1,0,0,0\n", ReadEuroc);
}

TEST(KittiPoses, Nominal) {
  std::istringstream in(
      "1 0 0 0.5 0 1 0 -1 0 0 1 2\n"
      "9.999978e-01 5.272628e-04 -2.066935e-03 -4.690294e-02 -5.296506e-04 9.999992e-01 -1.154865e-03 "
      "-2.839928e-02 2.066324e-03 1.155958e-03 9.999971e-01 8.586941e-01\n"
      "\n");
  const std::vector<Eigen::Isometry3d> poses = ReadKittiPoses(in, "00.txt");
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_TRUE(poses[0].translation().isApprox(Eigen::Vector3d(0.5, -1, 2)));
  // Re-orthonormalised, and within print rounding of the file's matrix.
  const Eigen::Matrix3d R = poses[1].linear();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R(0, 1), 5.272628e-04, 2e-6);
  EXPECT_NEAR(poses[1].translation().z(), 8.586941e-01, 1e-15);

  std::istringstream times("0.000000e+00\n1.037359e-01\n");
  const Trajectory t = MakeKittiTrajectory(poses, "00.txt", ReadKittiTimes(times, "times.txt"), "times.txt");
  EXPECT_TRUE(t.has_times);
  EXPECT_EQ(t.poses[1].t_ns, 103735900);
  const Trajectory indexed = MakeKittiTrajectory(poses, "00.txt", std::nullopt, "");
  EXPECT_FALSE(indexed.has_times);
  EXPECT_EQ(indexed.poses[1].t_ns, 1);
}

TEST(KittiPoses, Malformed) {
  std::string msg;
  InputLocation at = ErrorAt("1 0 0 0 0 1 0 0 0 0 1\n", ReadKitti, &msg);
  EXPECT_EQ(at.line, 1);
  EXPECT_NE(msg.find("expected 12"), std::string::npos) << msg;
  at = ErrorAt("1 0 0 0 0 1 0 0 0 0 1 0\n\n1 0 0 0 0 1 0 0 0 0 1 0\n", ReadKitti, &msg);
  EXPECT_EQ(at.line, 2);
  EXPECT_NE(msg.find("blank line"), std::string::npos) << msg;
  at = ErrorAt("1 0 0 0 0 1 0 0 0 0 1 0\n2 0 0 0 0 1 0 0 0 0 1 0\n", ReadKitti, &msg);  // scaled
  EXPECT_EQ(at.line, 2);
  EXPECT_NE(msg.find("not a rotation"), std::string::npos) << msg;
  at = ErrorAt("1 0 0 0 0 1 0 0 0 0 -1 0\n", ReadKitti, &msg);  // reflection
  EXPECT_NE(msg.find("det"), std::string::npos) << msg;
  at = ErrorAt("1 0 0 0 0 1 0 0 0 0 1 -inf\n", ReadKitti, &msg);
  EXPECT_EQ(at.column, 23);
  EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;

  at = ErrorAt("0.1\n0.09\n", ReadTimes, &msg);
  EXPECT_EQ(at.path, "times.txt");
  EXPECT_EQ(at.line, 2);
  ErrorAt("0.1 0.2\n", ReadTimes);

  const std::vector<Eigen::Isometry3d> one(1, Eigen::Isometry3d::Identity());
  try {
    MakeKittiTrajectory(one, "00.txt", std::vector<int64_t>{1, 2}, "times.txt");
    ADD_FAILURE() << "count mismatch accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "times.txt");
  }
}

void ExpectSame(const Trajectory& a, const Trajectory& b, bool compare_times) {
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (size_t i = 0; i < a.poses.size(); ++i) {
    if (compare_times) {
      ASSERT_EQ(a.poses[i].t_ns, b.poses[i].t_ns);
    }
    ASSERT_LT((a.poses[i].T_world_frame.matrix() - b.poses[i].T_world_frame.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(TrajectoryWriters, RoundTrip) {
  Trajectory t;
  for (int i = 0; i < 50; ++i) {
    StampedPose p;
    p.t_ns = INT64_C(1403715524907143168) + i * INT64_C(50000001);
    p.T_world_frame = Eigen::Translation3d(0.1 * i, -3.0 / (i + 1), 1e-7 * i) *
                      Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(1, 2, 3).normalized());
    t.poses.push_back(p);
  }
  std::stringstream tum, euroc, kitti;
  WriteTumTrajectory(tum, t);
  WriteEurocTrajectory(euroc, t);
  WriteKittiPoses(kitti, t);
  ExpectSame(t, ReadTumTrajectory(tum, "rt.tum"), true);
  ExpectSame(t, ReadEurocTrajectory(euroc, "rt.csv"), true);
  ExpectSame(t, MakeKittiTrajectory(ReadKittiPoses(kitti, "rt.txt"), "rt.txt", std::nullopt, ""), false);
}

TEST(RealTrajectories, Nominal) {
  SKIP_WITHOUT_EVO_DATA();
  const fs::path d = EvoData();
  const Trajectory kitti = ReadTrajectory(d / "KITTI_00_gt.txt", std::nullopt, d / "KITTI_00_gt_times.txt");
  ASSERT_EQ(kitti.poses.size(), 4541u);
  EXPECT_EQ(kitti.poses[1].t_ns, 103735900);  // 1.037359e-01
  EXPECT_NEAR(kitti.poses[1].T_world_frame.translation().z(), 8.586941e-01, 1e-15);
  EXPECT_EQ(DetectTrajectoryFormat(d / "KITTI_00_ORB.txt"), TrajectoryFormat::kKitti);

  const Trajectory gt = ReadTrajectory(d / "V102_groundtruth.csv", std::nullopt);
  ASSERT_EQ(gt.poses.size(), 16702u);
  EXPECT_EQ(gt.poses[0].t_ns, INT64_C(1403715524907143168));

  const Trajectory est = ReadTrajectory(d / "V102.txt", std::nullopt);
  ASSERT_EQ(est.poses.size(), 807u);
  EXPECT_EQ(est.poses[0].t_ns, INT64_C(1403715529112143517));  // 1.403715529112143517e+09, every digit

  const Trajectory geo = ReadTrajectory(d / "georeferenced.tum", TrajectoryFormat::kTum);
  EXPECT_EQ(geo.poses.size(), 1000u);
  EXPECT_NEAR(geo.poses[0].T_world_frame.translation().y(), 5.429380172093272209e+06, 1e-9);
}

TEST(TrajectoryFile, Malformed) {
  EXPECT_FALSE(ParseTrajectoryFormat("csv"));
  EXPECT_EQ(ParseTrajectoryFormat("asl"), TrajectoryFormat::kEuroc);
  try {
    ReadTrajectory("/nonexistent/traj.txt", std::nullopt);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "/nonexistent/traj.txt");
  }
}

}  // namespace
}  // namespace rs
