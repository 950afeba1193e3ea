#include "formats/stereo/calibration_yaml.h"

#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <sstream>

#include "formats/input_error.h"

namespace rs {
namespace {

// EuRoC V1_01 cam0/cam1 intrinsics with a 11 cm baseline and a small rotation.
StereoCalibration RawSample() {
  StereoCalibration c;
  c.left = {752, 480, 458.654, 457.296, 367.215, 248.375, {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0}};
  c.right = {752, 480, 457.587, 456.134, 379.999, 255.238, {-0.28368365, 0.07451284, -0.00010473, -3.555907e-05, 0}};
  const double a = 0.01;  // rad about y
  c.R_right_left = {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)};
  c.t_right_left = {-0.110073808127187, 0.000399121956463, -0.000853702503305};
  return c;
}

std::string Write(const StereoCalibration& c) {
  std::stringstream s;
  WriteCalibrationYaml(s, c);
  return s.str();
}

// Expects reading text to fail with a message containing `needle`.
void ExpectRejected(const std::string& text, const std::string& needle) {
  std::stringstream in(text);
  try {
    ReadCalibrationYaml(in, "cal.yaml");
    FAIL() << "accepted; expected an error mentioning " << needle;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cal.yaml"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find(needle), std::string::npos) << e.what();
  }
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  const size_t p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

TEST(CalibrationYaml, Nominal) {
  const StereoCalibration c = RawSample();
  const std::string text = Write(c);
  EXPECT_NE(text.find("format: \"roadsurvey-stereo-calibration-v1\""), std::string::npos) << text;
  EXPECT_NE(text.find("R_right_left: !!opencv-matrix"), std::string::npos);
  std::stringstream in(text);
  const StereoCalibration r = ReadCalibrationYaml(in, "cal.yaml");
  EXPECT_EQ(r.source_path, "cal.yaml");
  EXPECT_FALSE(r.rectified);
  EXPECT_EQ(r.left.width, 752);
  EXPECT_EQ(r.right.height, 480);
  // The writer prints %.17g: the round trip is bit-exact.
  auto near = [](double a, double b) { EXPECT_EQ(a, b); };
  near(r.left.fx, c.left.fx);
  near(r.left.cy, c.left.cy);
  near(r.right.cx, c.right.cx);
  near(r.right.fy, c.right.fy);
  for (int i = 0; i < 5; ++i) near(r.left.dist[i], c.left.dist[i]), near(r.right.dist[i], c.right.dist[i]);
  for (int i = 0; i < 9; ++i) near(r.R_right_left[i], c.R_right_left[i]);
  for (int i = 0; i < 3; ++i) near(r.t_right_left[i], c.t_right_left[i]);
  EXPECT_NEAR(r.BaselineM(), 0.11007784219324551, 1e-15);  // python math.hypot of t
}

TEST(CalibrationYaml, RectifiedRoundTrip) {
  StereoCalibration c;
  c.rectified = true;
  c.left = c.right = {1226, 370, 707.0912, 707.0912, 601.8873, 183.1104, {}};
  c.t_right_left = {-0.5371541, 0, 0};
  std::stringstream in(Write(c));
  const StereoCalibration r = ReadCalibrationYaml(in, "cal.yaml");
  EXPECT_TRUE(r.rectified);
  EXPECT_DOUBLE_EQ(r.BaselineM(), 0.5371541);
}

TEST(CalibrationYaml, FileRoundTrip) {
  const auto path = std::filesystem::temp_directory_path() / "rs_stereo_cal_roundtrip.yaml";
  WriteCalibrationYaml(path, RawSample());
  const StereoCalibration r = ReadCalibrationYaml(path);
  EXPECT_EQ(r.source_path, path.string());
  EXPECT_NEAR(r.left.fx, 458.654, 1e-12);
  std::filesystem::remove(path);
}

TEST(CalibrationYaml, BadFieldsNamed) {
  const std::string good = Write(RawSample());
  // Negative focal length in K_left (first element of its data).
  ExpectRejected(std::regex_replace(good, std::regex(R"(K_left: !!opencv-matrix\n(.*\n){3}   data: \[ )"), "$&-"),
                 "K_left.fx");
  ExpectRejected(Replace(good, "image_width: 752", "image_width: 75"), "K_left.cx");
  ExpectRejected(Replace(good, "image_width: 752", "image_width: -752"), "image_width");
  ExpectRejected(Replace(good, "rectified: 0", "rectified: 2"), "rectified");
  ExpectRejected(Replace(good, "format: \"roadsurvey-stereo-calibration-v1\"", "format: \"v0\""), "format");
  ExpectRejected(Replace(good, "rectified: 0\n", "rectified: 0\nbaseline: 3\n"), "unknown key 'baseline'");
  ExpectRejected(Replace(good, "rectified: 0\n", ""), "missing key 'rectified'");
  ExpectRejected(Replace(good, "rectified: 0", "rectified: 1"), "rectified = 1");
}

TEST(CalibrationYaml, ImpossibleGeometryRejected) {
  auto reject = [](StereoCalibration c, const std::string& needle) {
    std::stringstream s;
    try {
      WriteCalibrationYaml(s, c);
      FAIL() << "written; expected rejection mentioning " << needle;
    } catch (const InputError& e) {
      EXPECT_NE(e.message().find(needle), std::string::npos) << e.what();
    }
  };
  StereoCalibration c = RawSample();
  c.t_right_left = {0, 0, 0};
  reject(c, "baseline");
  c = RawSample();
  c.t_right_left = {-110, 0, 0};  // millimetres
  reject(c, "baseline");
  c = RawSample();
  c.R_right_left[0] = 1.1;
  reject(c, "orthonormal");
  c = RawSample();
  c.R_right_left = {1, 0, 0, 0, 1, 0, 0, 0, -1};
  reject(c, "det");
  c = RawSample();
  c.right.fy = 0;
  reject(c, "K_right.fy");
  c = RawSample();
  c.left.cy = 5000;
  reject(c, "K_left.cy");
}

TEST(CalibrationYaml, MalformedYamlNamesLine) {
  std::stringstream in("%YAML:1.0\nformat: \"roadsurvey-stereo-calibration-v1\"\nK_left: [1, 2\nfoo: : :\n");
  try {
    ReadCalibrationYaml(in, "cal.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "cal.yaml");
    EXPECT_NE(std::string(e.what()).find("YAML"), std::string::npos) << e.what();
  }
}

TEST(CalibrationYaml, MissingFile) {
  EXPECT_THROW(ReadCalibrationYaml(std::filesystem::path("/nonexistent/cal.yaml")), InputError);
}

}  // namespace
}  // namespace rs
