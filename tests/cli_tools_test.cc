// End-to-end tests of the file-level tools (stereo, segment, eval, bench, log): the built
// `roadsurvey` binary on small inputs made here with known truth, and on the public data
// under ROADSURVEY_DATA when present.
#include <gtest/gtest.h>
#include "tests/support/test_data.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "formats/flight_log/track_csv.h"
#include "formats/stereo/calibration_yaml.h"
#include "eval/disparity/disparity_eval.h"
#include "formats/disparity/disparity_io.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

struct RunResult {
  int code = -1;
  std::string output;  ///< stdout and stderr together
};

/// Runs `roadsurvey ARGS` (args are passed to the shell as written).
RunResult Roadsurvey(const std::string& args) {
  const std::string cmd = std::string(ROADSURVEY_BINARY_DIR) + "/roadsurvey " + args + " 2>&1";
  RunResult r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

fs::path DataRoot() { return rs::test::DataRoot(); }

/// A fresh folder per test, removed afterwards.
class CliTools : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rs_cli_tools_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!std::getenv("RS_KEEP")) fs::remove_all(dir_);
  }
  std::string P(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

/// The first number after `label` in `text` (NaN when absent).
double NumberAfter(const std::string& text, const std::string& label) {
  const auto at = text.find(label);
  if (at == std::string::npos) return NAN;
  std::smatch m;
  const std::string rest = text.substr(at + label.size());
  static const std::regex num(R"([-+]?[0-9]*\.?[0-9]+(e[-+]?[0-9]+)?)");
  return std::regex_search(rest, m, num) ? std::stod(m.str()) : NAN;
}

/// The default synthetic road at 640x360 (disparities and pothole halved with the size).
SyntheticRoadOptions SmallRoad() {
  SyntheticRoadOptions o;
  o.width = 640, o.height = 360;
  o.c0 = 30, o.pothole_u = 350, o.pothole_v = 260, o.pothole_radius_px = 45, o.pothole_depth_px = 2.5;
  return o;
}

// stereo -> KITTI PNG + transformed + preview + cloud; eval disparity on it; segment the
// transformed disparity; eval damage against the pothole's true disc.
TEST_F(CliTools, StereoSegmentEvalNominal) {
  const SyntheticRoadOptions o = SmallRoad();
  const StereoPairWithTruth pair = MakeSyntheticRoadPair(o);
  ASSERT_TRUE(cv::imwrite(P("left.png"), pair.left) && cv::imwrite(P("right.png"), pair.right));
  ASSERT_TRUE(cv::imwrite(P("gt.png"), ToKittiDisparity16(pair.gt, pair.gt > 0)));
  const double f_px = 500, baseline_m = 0.2;
  RunResult r = Roadsurvey(fmt::format(
      "stereo {} {} -o {} --transformed {} --preview {} --focal {} --baseline {} --cloud {}", P("left.png"),
      P("right.png"), P("disp.png"), P("transformed.tiff"), P("preview.png"), f_px, baseline_m, P("cloud.ply")));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("method          gpt-sgm"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("FELL BACK"), std::string::npos) << r.output;

  // The disparity PNG: valid KITTI 16-bit, mean over valid truth pixels within 0.05 px of the truth's.
  const cv::Mat png = cv::imread(P("disp.png"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(png.type(), CV_16UC1);
  ASSERT_EQ(png.size(), pair.left.size());
  cv::Mat d, valid;
  FromKittiDisparity16(png, &d, &valid);
  const cv::Mat region = valid & (pair.nonocc != 0);
  ASSERT_GT(cv::countNonZero(region), 0.8 * cv::countNonZero(pair.nonocc));
  EXPECT_NEAR(cv::mean(d, region)[0], cv::mean(pair.gt, region)[0], 0.05);
  // Printed road model d = a0 + a1 (v cos(phi) - u sin(phi)): a0 is the disparity at (0, 0), c0 = 30 px.
  EXPECT_NEAR(NumberAfter(r.output, "d = "), o.c0, 0.3) << r.output;

  // The point cloud: one point per valid pixel, Z = f B / d.
  std::ifstream ply(P("cloud.ply"), std::ios::binary);
  std::string line;
  int64_t vertices = -1;
  while (std::getline(ply, line) && line != "end_header")
    if (line.rfind("element vertex ", 0) == 0) vertices = std::stoll(line.substr(15));
  ASSERT_EQ(vertices, cv::countNonZero(valid));
  double inv_sum = 0;
  for (int64_t i = 0; i < vertices; ++i) {
    char rec[15];
    ply.read(rec, sizeof(rec));
    float xyz[3];
    std::memcpy(xyz, rec, sizeof(xyz));
    inv_sum += f_px * baseline_m / xyz[2];
  }
  ASSERT_TRUE(ply.good());
  // PNG disparities are rounded to 1/256 px; the cloud uses the unrounded values.
  EXPECT_NEAR(inv_sum / vertices, cv::mean(d, valid)[0], 1.0 / 256);

  // Range to the road at the principal point (image centre): Z = f B / d_true(cx, cy).
  const double cx = (o.width - 1) / 2.0, cy = (o.height - 1) / 2.0;
  EXPECT_NEAR(NumberAfter(r.output, "road range "), f_px * baseline_m / (o.c0 + o.cu * cx + o.cv * cy), 0.01)
      << r.output;

  const cv::Mat preview = cv::imread(P("preview.png"));
  EXPECT_EQ(preview.rows, pair.left.rows);

  // eval disparity: the numbers agree with the library on the same files, and with the truth.
  r = Roadsurvey(fmt::format("eval disparity {} {} --json {}", P("disp.png"), P("gt.png"), P("eval.json")));
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream ej(P("eval.json"));
  const nlohmann::json eval = nlohmann::json::parse(ej);
  cv::Mat gt32, gt_valid;
  FromKittiDisparity16(ToKittiDisparity16(pair.gt, pair.gt > 0), &gt32, &gt_valid);
  const DisparityMetrics m = EvaluateDisparity(d, valid, gt32);
  EXPECT_EQ(eval["total"]["all"]["evaluated"].get<int64_t>(), m.evaluated);
  EXPECT_NEAR(eval["total"]["all"]["epe_px"].get<double>(), m.epe, 1e-12);
  EXPECT_NEAR(eval["total"]["all"]["bad2"].get<double>(), m.bad2, 1e-12);
  EXPECT_LT(m.epe, 0.5);  // a textured plane: sub-pixel accuracy

  // Folders paired by file name, with non-occluded and mask regions: pooled totals add up.
  fs::create_directories(dir_ / "est"), fs::create_directories(dir_ / "gt"), fs::create_directories(dir_ / "noc");
  fs::create_directories(dir_ / "mask");
  for (const char* name : {"a.png", "b.png"}) {
    fs::copy_file(P("disp.png"), dir_ / "est" / name);
    fs::copy_file(P("gt.png"), dir_ / "gt" / name);
    ASSERT_TRUE(cv::imwrite((dir_ / "noc" / name).string(), pair.nonocc));
    ASSERT_TRUE(cv::imwrite((dir_ / "mask" / name).string(), pair.road));
  }
  r = Roadsurvey(
      fmt::format("eval disparity {} {} --noc {} --mask {} --json -", P("est"), P("gt"), P("noc"), P("mask")));
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json folders = nlohmann::json::parse(r.output);
  ASSERT_EQ(folders["files"].size(), 2u);
  EXPECT_EQ(folders["total"]["all"]["evaluated"].get<int64_t>(), 2 * m.evaluated);
  EXPECT_NEAR(folders["total"]["all"]["epe_px"].get<double>(), m.epe, 1e-12);
  EXPECT_EQ(folders["total"]["nonocc"]["evaluated"].get<int64_t>(), 2 * cv::countNonZero(pair.nonocc & (gt32 > 0)));
  const DisparityMetrics road = EvaluateDisparity(d, valid, gt32, pair.road);
  EXPECT_NEAR(folders["total"]["mask"]["bad1"].get<double>(), road.bad1, 1e-12);

  // segment the transformed disparity; the pothole is found where the truth disc is.
  r = Roadsurvey(fmt::format("segment {} -o {} --json {} --overlay {}", P("transformed.tiff"), P("labels.png"),
                             P("det.json"), P("overlay.png")));
  ASSERT_EQ(r.code, 0) << r.output;
  const cv::Mat labels = cv::imread(P("labels.png"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(labels.type(), CV_16UC1);
  EXPECT_GT(labels.at<uint16_t>(int(o.pothole_v), int(o.pothole_u)), 0);
  cv::Mat disc = cv::Mat::zeros(pair.left.size(), CV_16U);
  for (int v = 0; v < disc.rows; ++v)
    for (int u = 0; u < disc.cols; ++u)
      if (std::hypot(u - o.pothole_u, v - o.pothole_v) < o.pothole_radius_px) disc.at<uint16_t>(v, u) = 1;
  ASSERT_TRUE(cv::imwrite(P("truth.png"), disc));
  r = Roadsurvey(fmt::format("eval damage {} {} --json {}", P("labels.png"), P("truth.png"), P("damage.json")));
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream dj(P("damage.json"));
  const nlohmann::json dmg = nlohmann::json::parse(dj);
  // The disc's outer rim is only 0..0.5 px deep, below the noise, so the found region is smaller.
  EXPECT_GT(dmg["total"]["pixels"]["iou"].get<double>(), 0.7) << r.output;  // measured 0.84
  EXPECT_EQ(dmg["total"]["instances"]["truth"].get<int>(), 1);
  // Cross-check the pixel counts against the label images themselves.
  const int64_t tp = cv::countNonZero((labels != 0) & (disc != 0));
  EXPECT_EQ(dmg["total"]["pixels"]["tp"].get<int64_t>(), tp);
}

// Geometry from a native calibration.yaml (rectified): the same metric output as --focal/--baseline;
// a calibration for another image size is bad input.
TEST_F(CliTools, StereoCalibrationFile) {
  SyntheticRoadOptions o = SmallRoad();
  o.width = 320, o.height = 180, o.c0 = 15, o.pothole_u = 175, o.pothole_v = 130, o.pothole_radius_px = 22;
  const StereoPairWithTruth pair = MakeSyntheticRoadPair(o);
  ASSERT_TRUE(cv::imwrite(P("l.png"), pair.left) && cv::imwrite(P("r.png"), pair.right));
  StereoCalibration calib;
  calib.rectified = true;
  calib.left = {o.width, o.height, 400.0, 400.0, 160.0, 90.0, {}};
  calib.right = calib.left;
  calib.t_right_left = {-0.25, 0, 0};
  WriteCalibrationYaml(fs::path(P("calibration.yaml")), calib);
  RunResult r = Roadsurvey(
      fmt::format("stereo {} {} -o {} --calibration {}", P("l.png"), P("r.png"), P("d.png"), P("calibration.yaml")));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NEAR(NumberAfter(r.output, "road range "), 400.0 * 0.25 / (o.c0 + o.cu * 160.0 + o.cv * 90.0), 0.02)
      << r.output;
  EXPECT_NE(r.output.find("B = 0.2500 m"), std::string::npos) << r.output;
  // --calibration and --focal exclude each other.
  EXPECT_EQ(Roadsurvey(fmt::format("stereo {} {} -o {} --calibration {} --focal 400 --baseline 0.25", P("l.png"),
                                   P("r.png"), P("d.png"), P("calibration.yaml")))
                .code,
            2);
  // The same rig declared unrectified: the pair goes through StereoRectifier (identity geometry here,
  // so the range must not change).
  calib.rectified = false;
  WriteCalibrationYaml(fs::path(P("raw.yaml")), calib);
  r = Roadsurvey(fmt::format("stereo {} {} -o {} --calibration {}", P("l.png"), P("r.png"), P("d.png"), P("raw.yaml")));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("rectified the pair"), std::string::npos) << r.output;
  EXPECT_NEAR(NumberAfter(r.output, "road range "), 400.0 * 0.25 / (o.c0 + o.cu * 160.0 + o.cv * 90.0), 0.02)
      << r.output;
  calib.left.width = calib.right.width = 640;
  calib.left.cx = calib.right.cx = 320;
  WriteCalibrationYaml(fs::path(P("wrong.yaml")), calib);
  r = Roadsurvey(
      fmt::format("stereo {} {} -o {} --calibration {}", P("l.png"), P("r.png"), P("d2.png"), P("wrong.yaml")));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("calibrated for 640x180"), std::string::npos) << r.output;
}

TEST_F(CliTools, StereoMissingFile) {
  const RunResult r = Roadsurvey(fmt::format("stereo {} {} -o {}", P("nope_l.png"), P("nope_r.png"), P("d.png")));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("nope_l.png"), std::string::npos) << r.output;
}

TEST_F(CliTools, BadOptionValues) {
  const SyntheticRoadOptions o = SmallRoad();
  const StereoPairWithTruth pair = MakeSyntheticRoadPair(o);
  ASSERT_TRUE(cv::imwrite(P("l.png"), pair.left) && cv::imwrite(P("r.png"), pair.right));
  // Rejected by the flag's own check, by DisparityParams::Check, by a flag parser of ours.
  EXPECT_EQ(Roadsurvey(fmt::format("stereo {} {} -o {} --method bm", P("l.png"), P("r.png"), P("d.png"))).code, 2);
  const RunResult r =
      Roadsurvey(fmt::format("stereo {} {} -o {} --num-disparities 0", P("l.png"), P("r.png"), P("d.png")));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("num_disparities"), std::string::npos) << r.output;
  EXPECT_EQ(
      Roadsurvey(fmt::format("stereo {} {} -o {} --cloud {}", P("l.png"), P("r.png"), P("d.png"), P("c.ply"))).code, 2);
  EXPECT_EQ(Roadsurvey("bench damage --size 10x10").code, 2);
  EXPECT_EQ(Roadsurvey("bench damage --size wide").code, 2);
  EXPECT_FALSE(fs::exists(P("d.png")));   // nothing written on bad usage
  EXPECT_EQ(Roadsurvey("eval").code, 2);  // a subcommand is required
  EXPECT_EQ(Roadsurvey("--help").code, 0);
}

/// A roadsurvey track CSV: three fixes 0.001 deg apart due north, 1 s apart, and a camera event.
std::string TinyTrack() {
  return "# roadsurvey flight track v1, time_base=utc\n"
         "t_ns,type,lat_deg,lon_deg,alt_m,alt_ref,fix_type,satellites,h_acc_m,v_acc_m,qw,qx,qy,qz,sequence\n"
         "1700000000000000000,gnss,46.000,14.5,300,amsl,3,12,0.8,1.5,,,,,\n"
         "1700000000500000000,attitude,,,,,,,,,1,0,0,0,\n"
         "1700000001000000000,gnss,46.001,14.5,300,amsl,3,12,0.8,1.5,,,,,\n"
         "1700000001500000000,camera,46.0015,14.5,300,amsl,,,,,,,,,7\n"
         "1700000002000000000,gnss,46.002,14.5,301,amsl,6,14,0.02,0.03,,,,,\n";
}

/// Meridian arc between two nearby latitudes on WGS84: M(phi) * dphi at the midpoint (relative
/// error ~1e-10 for 0.001 deg steps).
double MeridianArcM(double lat0_deg, double lat1_deg) {
  const double a = 6378137.0, f = 1 / 298.257223563, e2 = f * (2 - f);
  const double phi = 0.5 * (lat0_deg + lat1_deg) * M_PI / 180, s = std::sin(phi);
  return a * (1 - e2) / std::pow(1 - e2 * s * s, 1.5) * std::abs(lat1_deg - lat0_deg) * M_PI / 180;
}

TEST_F(CliTools, LogNominal) {
  std::ofstream(P("track.csv")) << TinyTrack();
  const RunResult r = Roadsurvey("log " + P("track.csv"));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("format          roadsurvey-csv (detected)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("2023-11-14T22:13:20.000Z .. 2023-11-14T22:13:22.000Z (2.000 s)"), std::string::npos)
      << r.output;
  EXPECT_EQ(NumberAfter(r.output, "fixes "), 3);
  EXPECT_NE(r.output.find("3D: 2, RTK fixed: 1"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("amsl: 3"), std::string::npos) << r.output;
  EXPECT_EQ(NumberAfter(r.output, "attitude "), 1);
  EXPECT_EQ(NumberAfter(r.output, "camera events "), 1);
  const double step = MeridianArcM(46.0, 46.001), step2 = MeridianArcM(46.001, 46.002);
  EXPECT_NEAR(NumberAfter(r.output, "path length "), step + step2, 0.01) << r.output;
  EXPECT_NEAR(NumberAfter(r.output, "max speed "), std::max(step, step2), 0.01) << r.output;

  // --csv -: the normalized track alone on stdout, which reads back to the same fixes.
  const RunResult csv = Roadsurvey("log " + P("track.csv") + " --csv -");
  ASSERT_EQ(csv.code, 0) << csv.output;
  std::istringstream in(csv.output);
  const FlightTrack back = ReadTrackCsv(in, "stdout");
  ASSERT_EQ(back.fixes.size(), 3u);
  EXPECT_EQ(back.fixes[2].lat_deg, 46.002);
  EXPECT_EQ(back.camera_events.at(0).sequence, 7);
}

TEST_F(CliTools, LogMissingFile) {
  const RunResult r = Roadsurvey("log " + P("absent.ulg"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(Roadsurvey("log " + P("absent.ulg") + " --format tlog").code, 2);
}

TEST_F(CliTools, LogRealUlog) {
  const fs::path ulog = DataRoot() / "px4_ulog/test/sample_log_small.ulg";
  if (!fs::exists(ulog)) GTEST_SKIP() << "real data absent: " << ulog;
  const RunResult r = Roadsurvey("log " + ulog.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("px4-ulog (detected)"), std::string::npos) << r.output;
  // pyulog: vehicle_gps_position holds 32 messages (README.txt beside the file), near 63.417 N 10.408 E.
  EXPECT_EQ(NumberAfter(r.output, "fixes "), 32) << r.output;
  EXPECT_NEAR(NumberAfter(r.output, "bounding box    lat "), 63.417, 0.01) << r.output;
}

TEST_F(CliTools, EvalTrajectoryKitti) {
  const fs::path data = DataRoot() / "kitti_euroc_trajectories/evo/test/data";
  if (!fs::exists(data / "KITTI_00_gt.txt")) GTEST_SKIP() << "real data absent: " << data;
  const std::string gt = (data / "KITTI_00_gt.txt").string();
  // Ground truth against itself: every error is 0 (association by index: KITTI has no times).
  RunResult r = Roadsurvey(fmt::format("eval trajectory {} {} --json {}", gt, gt, P("self.json")));
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream self_in(P("self.json"));
  const nlohmann::json self = nlohmann::json::parse(self_in);
  EXPECT_EQ(self["matched_poses"].get<int>(), 4541);
  EXPECT_NEAR(self["ate_m"]["rmse"].get<double>(), 0.0, 1e-6);
  EXPECT_NEAR(self["rpe_translation_m"]["max"].get<double>(), 0.0, 1e-6);
  // ORB-SLAM2 stereo on KITTI 00 (evo's test data): ATE RMSE 1.3 m in the ORB-SLAM2 paper
  // (Mur-Artal & Tardos 2017, Table II); 1.303 m as docs/evaluation.md reports.
  r = Roadsurvey(fmt::format("eval trajectory {} {} --by-index --json -", (data / "KITTI_00_ORB.txt").string(), gt));
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json orb = nlohmann::json::parse(r.output);
  EXPECT_NEAR(orb["ate_m"]["rmse"].get<double>(), 1.303, 0.001);
  EXPECT_NEAR(orb["kitti"]["t_err_percent"].get<double>(), 0.70, 0.005);
}

TEST_F(CliTools, EvalTrajectoryBadUsage) {
  std::ofstream(P("a.tum")) << "0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n2 1 1 0 0 0 0 1\n3 0 1 1 0 0 0 1\n";
  EXPECT_EQ(Roadsurvey(fmt::format("eval trajectory {} {}", P("a.tum"), P("missing.tum"))).code, 2);
  EXPECT_EQ(Roadsurvey(fmt::format("eval trajectory {} {} --rde-delta 1.5", P("a.tum"), P("a.tum"))).code, 2);
  EXPECT_EQ(Roadsurvey(fmt::format("eval trajectory {} {} --align affine", P("a.tum"), P("a.tum"))).code, 2);
  const RunResult r = Roadsurvey(fmt::format("eval trajectory {} {} --rde-delta 2 --json -", P("a.tum"), P("a.tum")));
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["matched_poses"].get<int>(), 4);
  EXPECT_EQ(j["rde_m"]["count"].get<int>(), 2);  // pairs (0, 2), (1, 3)
}

// Measurement errors: predicted values from detections JSON, truth from damages.geojson, by matched id.
TEST_F(CliTools, EvalDamageMeasurements) {
  cv::Mat pred = cv::Mat::zeros(100, 100, CV_16U), truth = cv::Mat::zeros(100, 100, CV_16U);
  pred(cv::Rect(10, 10, 40, 40)).setTo(1);
  truth(cv::Rect(12, 10, 40, 40)).setTo(5);  // IoU 1520 / 1680 = 0.905
  pred(cv::Rect(70, 70, 20, 20)).setTo(2);   // a false positive
  fs::create_directories(dir_ / "pred"), fs::create_directories(dir_ / "truth"), fs::create_directories(dir_ / "det");
  ASSERT_TRUE(cv::imwrite(P("pred/f1.png"), pred) && cv::imwrite(P("truth/f1.png"), truth));
  std::ofstream(P("det/f1.json"))
      << R"({"detections": [{"id": 1, "area_m2": 0.30, "max_depth_m": 0.05, "volume_m3": null},
                                                        {"id": 2, "area_m2": 0.01, "max_depth_m": 0.02, "volume_m3": 0.0001}]})";
  std::ofstream(P("damages.geojson")) << R"({"type": "FeatureCollection", "features": [{"type": "Feature",
      "geometry": {"type": "Polygon", "coordinates": [[[14.5, 46.0], [14.5001, 46.0], [14.5001, 46.0001], [14.5, 46.0]]]},
      "properties": {"id": 5, "area_m2": 0.25, "max_depth_m": 0.06, "volume_m3": 0.004}}]})";
  const RunResult r = Roadsurvey(fmt::format("eval damage {} {} --detections {} --truth {} --json {}", P("pred"),
                                             P("truth"), P("det"), P("damages.geojson"), P("e.json")));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("area       bias +500 cm2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("max depth  bias -10 mm"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("volume     no pair with both values"), std::string::npos) << r.output;
  std::ifstream in(P("e.json"));
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["total"]["instances"]["matched"].get<int>(), 1);
  EXPECT_EQ(j["total"]["instances"]["predicted"].get<int>(), 2);
  EXPECT_NEAR(j["files"][0]["instances"]["matches"][0]["iou"].get<double>(), 1520.0 / 1680.0, 1e-9);
  EXPECT_NEAR(j["total"]["area_error_m2"]["bias"].get<double>(), 0.05, 1e-12);
  EXPECT_EQ(j["total"]["pixels"]["tp"].get<int64_t>(), 1520);
  EXPECT_EQ(j["total"]["pixels"]["fp"].get<int64_t>(), 80 + 400);
  EXPECT_EQ(j["total"]["pixels"]["fn"].get<int64_t>(), 80);
  // A detections file that is not JSON is bad input.
  std::ofstream(P("det/f1.json")) << "{\"detections\": [";
  EXPECT_EQ(Roadsurvey(fmt::format("eval damage {} {} --detections {}", P("pred"), P("truth"), P("det"))).code, 2);
}

// Crack scoring with a tolerance: a one-pixel line 2 px from the truth counts whole, one 3 px away
// not at all; counts exact.
TEST_F(CliTools, EvalDamageCrackTolerance) {
  fs::create_directories(dir_ / "cp"), fs::create_directories(dir_ / "ct");
  cv::Mat truth = cv::Mat::zeros(40, 60, CV_16U), near = truth.clone(), far = truth.clone();
  truth(cv::Range(20, 21), cv::Range(10, 50)).setTo(1);
  near(cv::Range(22, 23), cv::Range(10, 50)).setTo(1);
  far(cv::Range(23, 24), cv::Range(10, 50)).setTo(1);
  ASSERT_TRUE(cv::imwrite(P("cp/a.png"), near) && cv::imwrite(P("ct/a.png"), truth));
  ASSERT_TRUE(cv::imwrite(P("cp/b.png"), far) && cv::imwrite(P("ct/b.png"), truth));
  const RunResult r =
      Roadsurvey(fmt::format("eval damage {} {} --tolerance-px 2 --json {}", P("cp"), P("ct"), P("t.json")));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("crack pixels within 2 px"), std::string::npos) << r.output;
  std::ifstream in(P("t.json"));
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& c = j["total"]["crack_pixels"];
  EXPECT_EQ(c["predicted"].get<int64_t>(), 80);
  EXPECT_EQ(c["predicted_near"].get<int64_t>(), 40);
  EXPECT_EQ(c["truth"].get<int64_t>(), 80);
  EXPECT_EQ(c["truth_near"].get<int64_t>(), 40);
  EXPECT_DOUBLE_EQ(c["f1"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(j["files"][0]["crack_pixels"]["f1"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(j["files"][1]["crack_pixels"]["f1"].get<double>(), 0.0);
}

// eval cracks on a folder: one textured image with a dark 5 px line and its mask; the line is
// found (precision and recall ≥ 0.9 at 2 px); a folder without masks/ is bad input.
TEST_F(CliTools, EvalCracksFolder) {
  fs::create_directories(dir_ / "cf/images"), fs::create_directories(dir_ / "cf/masks");
  cv::Mat noise(240, 320, CV_32F), img, mask = cv::Mat::zeros(240, 320, CV_8U);
  cv::RNG rng(11);
  rng.fill(noise, cv::RNG::NORMAL, 128, 10);
  noise.convertTo(img, CV_8U);
  cv::line(img, {30, 40}, {290, 200}, cv::Scalar(60), 5);
  cv::line(mask, {30, 40}, {290, 200}, cv::Scalar(255), 5);
  ASSERT_TRUE(cv::imwrite(P("cf/images/x.png"), img) && cv::imwrite(P("cf/masks/x.png"), mask));
  const RunResult r = Roadsurvey(fmt::format("eval cracks {} --json {}", P("cf"), P("c.json")));
  ASSERT_EQ(r.code, 0) << r.output;
  std::ifstream in(P("c.json"));
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["total"]["images"].get<int>(), 1);
  EXPECT_EQ(j["total"]["images_without_crack"].get<int>(), 0);
  EXPECT_GE(j["total"]["precision"].get<double>(), 0.9) << r.output;
  EXPECT_GE(j["total"]["recall"].get<double>(), 0.9) << r.output;
  EXPECT_EQ(j["images"][0]["truth"].get<int64_t>(), cv::countNonZero(mask));
  fs::remove_all(dir_ / "cf/masks");
  EXPECT_EQ(Roadsurvey(fmt::format("eval cracks {}", P("cf"))).code, 2);
}

TEST_F(CliTools, EvalDamageRealLabels) {
  const fs::path d3 = DataRoot() / "pothole_stereo_fan2019/dataset3";
  if (!fs::exists(d3 / "disp_tg/01.png")) GTEST_SKIP() << "real data absent: " << d3;
  // The authors' transformed disparity, segmented, against their RGB pothole mask.
  RunResult r = Roadsurvey(fmt::format("segment {} -o {}", (d3 / "disp_tg/01.png").string(), P("01.png")));
  ASSERT_EQ(r.code, 0) << r.output;
  r = Roadsurvey(fmt::format("eval damage {} {} --components --json -", P("01.png"), (d3 / "label/01.png").string()));
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_GT(j["total"]["pixels"]["f1"].get<double>(), 0.85) << r.output;  // measured 0.912
  EXPECT_GE(j["total"]["instances"]["matched"].get<int>(), 1) << r.output;
}

TEST_F(CliTools, BenchNominal) {
  RunResult r = Roadsurvey("bench damage --size 320x180 --frames 1");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("| 320x180 | 1 |"), std::string::npos) << r.output;
  r = Roadsurvey("bench disparity --synthetic 320x180 --repeat 1 --threads 1");
  ASSERT_EQ(r.code, 0) << r.output;
  // Every method's row; our GPT-SGM's EPE (last column) on the exact synthetic truth is sub-pixel.
  for (const char* method : {"| gpt-sgm |", "| sgm |", "| sgbm |", "| sgbm-3way |"})
    EXPECT_NE(r.output.find(method), std::string::npos) << r.output;
  const auto row = r.output.find("| gpt-sgm |");
  const std::string line = r.output.substr(row, r.output.find('\n', row) - row);
  const auto last = line.rfind('|', line.size() - 2);
  EXPECT_LT(std::stod(line.substr(last + 1)), 0.5) << line;
}

}  // namespace
}  // namespace rs
