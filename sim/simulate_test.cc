#include "sim/simulate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <GeographicLib/LocalCartesian.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "formats/flight_log/dataflash/dataflash_track.h"
#include "formats/flight_log/flight_log.h"
#include "formats/flight_log/track_csv.h"
#include "formats/geojson/geojson.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/flight_log/ulog/ulog_track.h"
#include "sim/flight_log_sim.h"
#include "sim/road_scene.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

/// Small, fast configuration: 320x192 images, few frames, lots of damage.
SimulationOptions SmallOptions() {
  SimulationOptions o = PresetOptions("demo");
  o.image_width = 320;
  o.image_height = 192;
  o.focal_px = 250;
  o.altitude_m = 3.0;
  o.num_frames = 6;
  o.frame_rate_hz = 10;
  o.potholes_per_100m = 80;
  o.noise_sigma_dn = 0;
  o.right_gain = 1.0;
  o.vignetting = 0;
  o.clock_offset_s = 0.25;
  o.gnss_noise_m = 0.02;
  o.gnss_bias_m = 0.01;
  o.parked_cars = 1;
  return o;
}

struct TumPose {
  double t_s;
  Eigen::Isometry3d T_world_cam;
};

std::vector<TumPose> ReadTum(const fs::path& p) {
  std::ifstream f(p);
  std::vector<TumPose> out;
  std::string line;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double t, x, y, z, qx, qy, qz, qw;
    ss >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
    TumPose pose{t, Eigen::Isometry3d::Identity()};
    pose.T_world_cam.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    pose.T_world_cam.translation() = Eigen::Vector3d(x, y, z);
    out.push_back(pose);
  }
  return out;
}

class SimulateTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("rs_simulate_test_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    summary_ = new SimulationSummary(Simulate(SmallOptions(), *dir_));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete summary_;
  }
  /// The scene exactly as Simulate built it (same options, same damage range).
  static sim::RoadScene Scene() {
    std::ifstream f(*dir_ / "truth/scene.json");
    const auto j = nlohmann::json::parse(f);
    return sim::RoadScene(SmallOptions(), j["damage_s_range_m"][0].get<double>(),
                          j["damage_s_range_m"][1].get<double>());
  }
  static fs::path* dir_;
  static SimulationSummary* summary_;
};
fs::path* SimulateTest::dir_ = nullptr;
SimulationSummary* SimulateTest::summary_ = nullptr;

TEST_F(SimulateTest, Nominal) {
  const fs::path& d = *dir_;
  EXPECT_EQ(summary_->frames, 6);
  for (const char* f : {"timestamps.csv", "calibration.yaml", "flight_log.csv", "flight_log.gpx", "flight_log.ulg",
                        "flight_log.bin", "survey.json", "truth/trajectory.tum", "truth/damages.geojson",
                        "truth/road_surface.ply", "truth/georeference.json", "truth/scene.json"}) {
    EXPECT_TRUE(fs::exists(d / f)) << f;
  }
  for (int k = 0; k < 6; ++k) {
    const std::string name = "00000" + std::to_string(k) + ".png";
    for (const char* sub : {"left/", "right/", "truth/disparity/", "truth/masks/"}) {
      EXPECT_TRUE(fs::exists(d / (std::string(sub) + name))) << sub << name;
    }
  }
  std::ifstream ts(d / "timestamps.csv");
  std::string line;
  std::getline(ts, line);
  EXPECT_EQ(line, "filename,t_ns");
  std::getline(ts, line);
  EXPECT_EQ(line, "000000.png,1700000000250000000");  // camera clock = log clock + 0.25 s

  const StereoCalibration calib = ReadCalibrationYaml(d / "calibration.yaml");
  EXPECT_TRUE(calib.rectified);
  EXPECT_EQ(calib.left.width, 320);
  EXPECT_NEAR(calib.BaselineM(), 0.3, 1e-12);

  const FlightTrack track = ReadTrackCsv(d / "flight_log.csv");
  EXPECT_EQ(track.camera_events.size(), 6u);
  EXPECT_GE(track.fixes.size(), 25u);      // 10 Hz over 0.5 s + 2 s margin
  EXPECT_GE(track.attitude.size(), 120u);  // 50 Hz

  const auto fc = geojson::ReadFeatureCollection(d / "truth/damages.geojson");
  EXPECT_EQ(static_cast<int>(fc.features.size()), summary_->damages);
  const sim::RoadScene scene = Scene();
  ASSERT_EQ(fc.features.size(), scene.damages().size());
  const GeographicLib::LocalCartesian enu(46.0569, 14.5058, 300.0);
  for (size_t k = 0; k < fc.features.size(); ++k) {
    const auto& p = fc.features[k].properties;
    const sim::Damage& dm = scene.damages()[k];
    EXPECT_EQ(p["id"].get<int>(), dm.id);
    EXPECT_NEAR(p["volume_m3"].get<double>(), dm.volume_m3, 1e-12);
    for (const char* key : {"type", "area_m2", "max_depth_m", "mean_depth_m", "volume_m3", "severity"}) {
      EXPECT_TRUE(p.contains(key)) << key;
    }
    // The outline lies where the damage is: its first vertex maps back to the outline's road point.
    const auto* pg = std::get_if<geojson::Polygon>(&fc.features[k].geometry);
    const auto* ls = std::get_if<geojson::LineString>(&fc.features[k].geometry);
    ASSERT_TRUE(pg || ls);
    const geojson::Position q = pg ? pg->rings[0][0] : ls->positions[0];
    double x, y, z;
    enu.Forward(q.lat_deg, q.lon_deg, 300.0, x, y, z);
    double s, l;
    scene.road().ToRoad(x, y, &s, &l);
    // One of the outline vertices is within 2 mm (8-decimal rounding ~1 mm; the writer may rotate the ring).
    double best = 1e9;
    for (const auto& v : dm.outline_sl) best = std::min(best, std::hypot(v.x() - s, v.y() - l));
    EXPECT_LT(best, 0.002);
  }
}

TEST_F(SimulateTest, DisparityIsDepthOfSurface) {
  // GT disparity = f*B/Z: back-projecting it with the GT pose lands on the GT surface.
  const sim::RoadScene scene = Scene();
  const auto poses = ReadTum(*dir_ / "truth/trajectory.tum");
  ASSERT_EQ(poses.size(), 6u);
  const StereoCalibration calib = ReadCalibrationYaml(*dir_ / "calibration.yaml");
  const double f = calib.left.fx, B = calib.BaselineM();
  int checked = 0, off = 0;
  for (int k = 0; k < 6; k += 5) {
    const cv::Mat disp =
        cv::imread((*dir_ / ("truth/disparity/00000" + std::to_string(k) + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(disp.type(), CV_16UC1);
    for (int v = 0; v < disp.rows; v += 3) {
      for (int u = 0; u < disp.cols; u += 3) {
        const uint16_t raw = disp.at<uint16_t>(v, u);
        if (raw == 0) continue;
        const double Z = f * B / (raw / 256.0);
        const Eigen::Vector3d pc((u - calib.left.cx) / f * Z, (v - calib.left.cy) / f * Z, Z);
        const Eigen::Vector3d pw = poses[k].T_world_cam * pc;
        // Depth quantization: dZ = Z^2/(f B) / 512 ~ 0.3 mm here; TUM rounding 1 um.
        const double dz = std::abs(pw.z() - scene.HeightAt(pw.x(), pw.y()));
        ++checked;
        if (dz > 0.002) ++off;  // obstacles (the parked car) are not part of the heightfield
      }
    }
  }
  EXPECT_GT(checked, 5000);
  EXPECT_LT(off, checked / 8) << off << " of " << checked << " back-projected pixels are off the surface";
}

TEST_F(SimulateTest, StereoReprojectionMatchesImages) {
  // Warping the right image into the left with GT disparity reproduces the left
  // image: textured pixels differ by < 2 grey levels (median) and < 15 (95th pct; occlusion edges).
  for (int k : {0, 3}) {
    const std::string name = "00000" + std::to_string(k) + ".png";
    const cv::Mat L = cv::imread((*dir_ / "left" / name).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat R = cv::imread((*dir_ / "right" / name).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat D = cv::imread((*dir_ / "truth/disparity" / name).string(), cv::IMREAD_UNCHANGED);
    std::vector<double> err;
    for (int v = 1; v + 1 < L.rows; ++v) {
      for (int u = 1; u + 1 < L.cols; ++u) {
        const uint16_t raw = D.at<uint16_t>(v, u);
        if (raw == 0) continue;
        const double x = u - raw / 256.0;
        if (x < 0 || x > R.cols - 2) continue;
        const int lap = std::abs(4 * L.at<uint8_t>(v, u) - L.at<uint8_t>(v, u - 1) - L.at<uint8_t>(v, u + 1) -
                                 L.at<uint8_t>(v - 1, u) - L.at<uint8_t>(v + 1, u));
        if (lap < 8) continue;  // textured pixels only
        const int x0 = static_cast<int>(x);
        const double w = x - x0;
        const double r = (1 - w) * R.at<uint8_t>(v, x0) + w * R.at<uint8_t>(v, x0 + 1);
        err.push_back(std::abs(r - L.at<uint8_t>(v, u)));
      }
    }
    ASSERT_GT(err.size(), 3000u);
    std::sort(err.begin(), err.end());
    std::printf("frame %d: %zu textured pixels, median %.2f, p95 %.2f grey levels\n", k, err.size(),
                err[err.size() / 2], err[err.size() * 95 / 100]);
    EXPECT_LT(err[err.size() / 2], 2.0) << "frame " << k;
    EXPECT_LT(err[err.size() * 95 / 100], 15.0) << "frame " << k;
  }
}

TEST_F(SimulateTest, GnssAgreesWithTruth) {
  const FlightTrack track = ReadTrackCsv(*dir_ / "flight_log.csv");
  const auto poses = ReadTum(*dir_ / "truth/trajectory.tum");
  const GeographicLib::LocalCartesian enu(46.0569, 14.5058, 300.0);
  const SimulationOptions o = SmallOptions();
  double sum2 = 0;
  int n = 0;
  for (const GnssFix& f : track.fixes) {
    // Log clock -> camera clock, then interpolate the truth (frames at 10 Hz).
    const double t_cam = (f.t_ns + 250'000'000) * 1e-9;
    if (t_cam < poses.front().t_s || t_cam > poses.back().t_s) continue;
    size_t k = 0;
    while (k + 2 < poses.size() && poses[k + 1].t_s < t_cam) ++k;
    const double a = (t_cam - poses[k].t_s) / (poses[k + 1].t_s - poses[k].t_s);
    const Eigen::Vector3d truth =
        (1 - a) * poses[k].T_world_cam.translation() + a * poses[k + 1].T_world_cam.translation();
    double x, y, z;
    enu.Forward(f.lat_deg, f.lon_deg, f.alt_m, x, y, z);
    sum2 += std::pow(x - truth.x(), 2) + std::pow(y - truth.y(), 2);
    ++n;
    EXPECT_EQ(f.alt_ref, AltitudeReference::kEllipsoid);
  }
  ASSERT_GE(n, 5);
  // Expected horizontal RMS = sqrt(2 (noise^2 + bias^2)) = 0.032 m; 3x margin for few samples.
  const double sigma = std::sqrt(2 * (o.gnss_noise_m * o.gnss_noise_m + o.gnss_bias_m * o.gnss_bias_m));
  const double rms = std::sqrt(sum2 / n);
  EXPECT_LT(rms, 3 * sigma);
  EXPECT_GT(rms, 0.2 * sigma);  // the noise is really there
  // Attitude (body FRD -> NED) at frame times equals the truth within the configured noise.
  Eigen::Matrix3d R_ned_enu, R_body_cam;
  R_ned_enu << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  R_body_cam << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // nadir camera: x right, y backward, z down
  int att = 0;
  for (const AttitudeSample& a : track.attitude) {
    for (const TumPose& p : poses) {
      if (std::abs(a.t_ns * 1e-9 + 0.25 - p.t_s) > 1e-4) continue;
      const Eigen::Matrix3d truth = R_ned_enu * p.T_world_cam.linear() * R_body_cam.transpose();
      const Eigen::Quaterniond q(a.qw, a.qx, a.qy, a.qz);
      const double err_deg = Eigen::AngleAxisd(truth.transpose() * q.toRotationMatrix()).angle() * 180 / M_PI;
      EXPECT_LT(err_deg, 5 * std::sqrt(3.0) * o.attitude_noise_deg);
      ++att;
    }
  }
  EXPECT_EQ(att, 6);
  // Camera events carry the trigger time on the log clock and the (biased) position.
  ASSERT_EQ(track.camera_events.size(), poses.size());
  for (size_t k = 0; k < poses.size(); ++k) {
    const CameraEvent& e = track.camera_events[k];
    EXPECT_NEAR(e.t_ns * 1e-9 + 0.25, poses[k].t_s, 1e-6);
    double x, y, z;
    enu.Forward(e.lat_deg, e.lon_deg, e.alt_m, x, y, z);
    EXPECT_LT((Eigen::Vector3d(x, y, z) - poses[k].T_world_cam.translation()).norm(), 6 * o.gnss_bias_m);
  }
}

// flight_log.ulg and flight_log.bin hold the CSV's track within each format's quantization.
TEST_F(SimulateTest, AutopilotLogsMatchCsv) {
  const FlightTrack csv = ReadTrackCsv(*dir_ / "flight_log.csv");
  const FlightTrack ulg = ReadUlogTrack(*dir_ / "flight_log.ulg");
  const FlightTrack bin = ReadDataflashTrack(*dir_ / "flight_log.bin");
  EXPECT_EQ(DetectFlightLogFormat(*dir_ / "flight_log.ulg"), "px4-ulog");
  EXPECT_EQ(DetectFlightLogFormat(*dir_ / "flight_log.bin"), "ardupilot-dataflash");
  struct Quant {
    const FlightTrack* t;
    int64_t dt_ns;     // time: 1 us (ULog), 1 ms (DataFlash GPS ms; boot clock fitted to it)
    double alt_m;      // int32 mm / int32 cm (fixes)
    double cam_alt_m;  // float / int32 cm (camera events)
    double att_deg;    // float quaternion / centidegree Euler angles
  };
  for (const Quant& q : {Quant{&ulg, 1000, 0.5e-3, 1e-4, 1e-4}, Quant{&bin, 1'000'000, 0.5e-2, 0.5e-2, 0.0087}}) {
    const FlightTrack& t = *q.t;
    SCOPED_TRACE(t.format);
    EXPECT_EQ(t.time_base, TimeBase::kUtc);
    ASSERT_EQ(t.fixes.size(), csv.fixes.size());
    for (size_t i = 0; i < csv.fixes.size(); ++i) {
      const GnssFix &a = csv.fixes[i], &b = t.fixes[i];
      EXPECT_LE(std::llabs(a.t_ns - b.t_ns), q.dt_ns);
      EXPECT_NEAR(b.lat_deg, a.lat_deg, 0.5e-7 + 1e-12);
      EXPECT_NEAR(b.lon_deg, a.lon_deg, 0.5e-7 + 1e-12);
      // The logs store AMSL = ellipsoidal - N.
      EXPECT_EQ(b.alt_ref, AltitudeReference::kAmsl);
      EXPECT_NEAR(b.alt_m, a.alt_m - sim::kSimGeoidHeightM, q.alt_m + 1e-9);
      EXPECT_EQ(b.fix_type, a.fix_type);
      EXPECT_EQ(b.satellites, a.satellites);
    }
    ASSERT_EQ(t.attitude.size(), csv.attitude.size());
    for (size_t i = 0; i < csv.attitude.size(); ++i) {
      const AttitudeSample &a = csv.attitude[i], &b = t.attitude[i];
      EXPECT_LE(std::llabs(a.t_ns - b.t_ns), q.dt_ns);
      const double d = std::fabs(a.qw * b.qw + a.qx * b.qx + a.qy * b.qy + a.qz * b.qz);
      EXPECT_LT(2 * std::acos(std::min(1.0, d)) * 180 / M_PI, q.att_deg) << i;
    }
    ASSERT_EQ(t.camera_events.size(), csv.camera_events.size());
    for (size_t i = 0; i < csv.camera_events.size(); ++i) {
      const CameraEvent &a = csv.camera_events[i], &b = t.camera_events[i];
      // Log clock, like the CSV: camera clock (timestamps.csv) = this + clock_offset_s.
      EXPECT_LE(std::llabs(a.t_ns - b.t_ns), q.dt_ns);
      EXPECT_EQ(b.sequence, a.sequence);
      EXPECT_NEAR(b.lat_deg, a.lat_deg, 0.5e-7 + 1e-12);
      EXPECT_NEAR(b.lon_deg, a.lon_deg, 0.5e-7 + 1e-12);
      EXPECT_NEAR(b.alt_m, a.alt_m - sim::kSimGeoidHeightM, q.cam_alt_m);
    }
  }
  // Frame 0 is exposed at the log-clock start time; its camera-clock stamp is 0.25 s later.
  EXPECT_EQ(ulg.camera_events[0].t_ns, 1'700'000'000'000'000'000LL);
  EXPECT_EQ(bin.camera_events[0].t_ns, 1'700'000'000'000'000'000LL);
}

TEST_F(SimulateTest, MasksMatchScene) {
  const sim::RoadScene scene = Scene();
  const auto poses = ReadTum(*dir_ / "truth/trajectory.tum");
  const StereoCalibration calib = ReadCalibrationYaml(*dir_ / "calibration.yaml");
  const cv::Mat M = cv::imread((*dir_ / "truth/masks/000002.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat D = cv::imread((*dir_ / "truth/disparity/000002.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(M.type(), CV_16UC1);
  int labelled = 0, agree = 0;
  for (int v = 0; v < M.rows; ++v) {
    for (int u = 0; u < M.cols; ++u) {
      const int id = M.at<uint16_t>(v, u);
      if (id == 0 || D.at<uint16_t>(v, u) == 0) continue;
      const double Z = calib.left.fx * calib.BaselineM() / (D.at<uint16_t>(v, u) / 256.0);
      const Eigen::Vector3d pw = poses[2].T_world_cam * Eigen::Vector3d((u - calib.left.cx) / calib.left.fx * Z,
                                                                        (v - calib.left.cy) / calib.left.fy * Z, Z);
      ++labelled;
      if (scene.LabelAt(pw.x(), pw.y()) == id) ++agree;
    }
  }
  EXPECT_GT(labelled, 200);
  EXPECT_GT(agree, labelled * 9 / 10);
}

TEST_F(SimulateTest, Deterministic) {
  const fs::path other = *dir_ / "again";
  Simulate(SmallOptions(), other);
  auto bytes = [](const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  EXPECT_EQ(bytes(other / "left/000001.png"), bytes(*dir_ / "left/000001.png"));
  EXPECT_EQ(bytes(other / "right/000001.png"), bytes(*dir_ / "right/000001.png"));
  EXPECT_EQ(bytes(other / "truth/damages.geojson"), bytes(*dir_ / "truth/damages.geojson"));
  EXPECT_EQ(bytes(other / "flight_log.ulg"), bytes(*dir_ / "flight_log.ulg"));
  EXPECT_EQ(bytes(other / "flight_log.bin"), bytes(*dir_ / "flight_log.bin"));
}

}  // namespace
}  // namespace rs

namespace rs {
namespace {

TEST(SimulateModes, CarRawBlurJpeg) {
  const fs::path dir = fs::temp_directory_path() / ("rs_simulate_modes_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  SimulationOptions car = PresetOptions("car");
  car.image_width = 256;
  car.image_height = 144;
  car.focal_px = 200;
  car.num_frames = 2;
  car.people = 1;
  Simulate(car, dir / "car");
  const cv::Mat D = cv::imread((dir / "car/truth/disparity/000000.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(D.empty());
  // Forward-looking at 15 deg down with a 40 deg vertical field: the top rows see sky, the bottom road.
  EXPECT_EQ(cv::countNonZero(D.row(0)), 0);
  EXPECT_EQ(cv::countNonZero(D.row(D.rows - 1)), D.cols);

  SimulationOptions raw = SmallOptions();
  raw.rectified = false;
  raw.motion_blur_samples = 3;
  raw.image_format = "jpg";
  raw.num_frames = 2;
  Simulate(raw, dir / "raw");
  EXPECT_TRUE(fs::exists(dir / "raw/left/000001.jpg"));
  EXPECT_FALSE(fs::exists(dir / "raw/truth/disparity/000001.png"));  // disparity only for rectified output
  const StereoCalibration calib = ReadCalibrationYaml(dir / "raw/calibration.yaml");
  EXPECT_FALSE(calib.rectified);
  EXPECT_NE(calib.left.dist[0], 0.0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rs
