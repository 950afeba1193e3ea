#include "formats/flight_log/ulog/ulog_writer.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "formats/flight_log/flight_log.h"
#include "formats/flight_log/ulog/ulog_file.h"
#include "formats/flight_log/ulog/ulog_track.h"
#include "formats/flight_log/writer_test_attitude.h"

namespace rs {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGeoidM = 47.25;
// 2023-11-14T22:13:20.000123456Z: deliberately not on a microsecond.
constexpr int64_t kT0 = 1'700'000'000'000'123'456LL;

// Truth attitude: roll/pitch oscillate, yaw turns through 360 deg several times.
AttitudeSample TruthAttitude(int64_t t_ns) { return test::TruthAttitudeAt(t_ns, (t_ns - kT0) * 1e-9); }

// 30 s: fixes at 5 Hz (ellipsoidal heights), attitude at 50 Hz, 20 camera events between samples.
FlightTrack TestTrack() {
  FlightTrack t;
  t.format = "csv";
  t.time_base = TimeBase::kUtc;
  for (int k = 0; k < 150; ++k) {
    GnssFix f;
    f.t_ns = kT0 + k * 200'000'000LL;
    f.lat_deg = 46.0569 + 1.234567e-6 * k;
    f.lon_deg = -122.3 - 0.7654321e-6 * k;  // negative: rounding must be symmetric
    f.alt_m = 300.0 + 0.01234 * k;
    f.alt_ref = AltitudeReference::kEllipsoid;
    f.fix_type = k % 2 ? 6 : 3;
    f.satellites = 10 + k % 7;
    f.h_acc_m = 0.02 + 0.001 * k;
    f.v_acc_m = 0.03;
    f.ground_speed_m_s = 4.2;
    t.fixes.push_back(f);
  }
  for (int k = 0; k < 1500; ++k) t.attitude.push_back(TruthAttitude(kT0 + k * 20'000'000LL));
  for (int k = 0; k < 20; ++k) {
    CameraEvent e;
    e.t_ns = kT0 + 1'000'000'000LL + k * 1'000'000'000LL + 7'777'777;  // between attitude samples
    e.sequence = 100 + k;
    e.lat_deg = 46.0569 + 1e-5 * k;
    e.lon_deg = 14.5058 + 2e-5 * k;
    e.alt_m = 310.5 + k;
    e.alt_ref = AltitudeReference::kEllipsoid;
    t.camera_events.push_back(e);
  }
  return t;
}

FlightTrack RoundTrip(const FlightTrack& in, const UlogWriteOptions& o, std::string* bytes = nullptr) {
  std::stringstream ss;
  WriteUlogTrack(ss, in, o);
  if (bytes) *bytes = ss.str();
  return ReadUlogTrack(ss, "mem.ulg");
}

TEST(UlogWriter, Nominal) {
  const FlightTrack in = TestTrack();
  UlogWriteOptions o;
  o.geoid_height_m = kGeoidM;
  o.sys_name = "roadsurvey-simulator";
  std::string bytes;
  const FlightTrack out = RoundTrip(in, o, &bytes);
  EXPECT_EQ(out.time_base, TimeBase::kUtc);
  ASSERT_EQ(out.fixes.size(), in.fixes.size());
  for (size_t i = 0; i < in.fixes.size(); ++i) {
    const GnssFix &a = in.fixes[i], &b = out.fixes[i];
    EXPECT_LE(std::llabs(a.t_ns - b.t_ns), 500) << i;  // rounded to the microsecond
    EXPECT_NEAR(b.lat_deg, a.lat_deg, 0.5e-7 + 1e-12) << i;
    EXPECT_NEAR(b.lon_deg, a.lon_deg, 0.5e-7 + 1e-12) << i;
    EXPECT_NEAR(b.alt_m, a.alt_m - kGeoidM, 0.5e-3 + 1e-9) << i;
    EXPECT_EQ(b.alt_ref, AltitudeReference::kAmsl);
    EXPECT_EQ(b.fix_type, a.fix_type);
    EXPECT_EQ(b.satellites, a.satellites);
    EXPECT_NEAR(b.h_acc_m, a.h_acc_m, 1e-7);
    EXPECT_NEAR(b.v_acc_m, a.v_acc_m, 1e-7);
    EXPECT_NEAR(b.ground_speed_m_s, a.ground_speed_m_s, 1e-6);
  }
  ASSERT_EQ(out.attitude.size(), in.attitude.size());
  for (size_t i = 0; i < in.attitude.size(); ++i) {
    const AttitudeSample &a = in.attitude[i], &b = out.attitude[i];
    EXPECT_LE(std::llabs(a.t_ns - b.t_ns), 500) << i;
    EXPECT_NEAR(b.qw, a.qw, 2e-7);  // float
    EXPECT_NEAR(b.qx, a.qx, 2e-7);
    EXPECT_NEAR(b.qy, a.qy, 2e-7);
    EXPECT_NEAR(b.qz, a.qz, 2e-7);
  }
  ASSERT_EQ(out.camera_events.size(), in.camera_events.size());
  for (size_t i = 0; i < in.camera_events.size(); ++i) {
    const CameraEvent &a = in.camera_events[i], &b = out.camera_events[i];
    EXPECT_LE(std::llabs(a.t_ns - b.t_ns), 500) << i;
    EXPECT_EQ(b.sequence, a.sequence);
    EXPECT_DOUBLE_EQ(b.lat_deg, a.lat_deg);  // double in camera_capture
    EXPECT_DOUBLE_EQ(b.lon_deg, a.lon_deg);
    EXPECT_NEAR(b.alt_m, a.alt_m - kGeoidM, 3e-5);  // float near 300 m
    EXPECT_EQ(b.alt_ref, AltitudeReference::kAmsl);
  }

  // What the track reader does not take: info, alt_ellipsoid, time fields, the camera quaternion.
  std::istringstream is(bytes);
  const ulog::UlogFile log = ulog::ReadUlogFile(is, "mem.ulg");
  EXPECT_EQ(log.version, 1);
  EXPECT_EQ(log.start_timestamp_us, 1'000'000u);
  EXPECT_EQ(log.InfoString("sys_name"), "roadsurvey-simulator");
  const ulog::Topic* gps = log.FindTopic("vehicle_gps_position");
  ASSERT_NE(gps, nullptr);
  const auto ie = gps->FieldIndex("alt_ellipsoid"), iu = gps->FieldIndex("time_utc_usec");
  ASSERT_TRUE(ie && iu);
  for (size_t r = 0; r < gps->size(); ++r) {
    EXPECT_NEAR(gps->IntValue(r, *ie) * 1e-3, in.fixes[r].alt_m, 1e-3);
    EXPECT_EQ(static_cast<int64_t>(gps->UInt64Value(r, *iu)), (in.fixes[r].t_ns + 500) / 1000);
    EXPECT_EQ(gps->TimestampUs(r), 1'000'000u + r * 200'000u);  // boot clock starts at 1 s
  }
  const ulog::Topic* cam = log.FindTopic("camera_capture");
  ASSERT_NE(cam, nullptr);
  const auto iq = cam->FieldIndex("q[0]"), iut = cam->FieldIndex("timestamp_utc"), ir = cam->FieldIndex("result");
  ASSERT_TRUE(iq && iut && ir);
  for (size_t r = 0; r < cam->size(); ++r) {
    // Interpolated between 50 Hz samples vs the analytic attitude: the interpolation error is < 1e-5.
    const AttitudeSample truth = TruthAttitude(in.camera_events[r].t_ns);
    EXPECT_NEAR(cam->Value(r, *iq), truth.qw, 1e-5) << r;
    EXPECT_NEAR(cam->Value(r, *iq + 1), truth.qx, 1e-5) << r;
    EXPECT_NEAR(cam->Value(r, *iq + 2), truth.qy, 1e-5) << r;
    EXPECT_NEAR(cam->Value(r, *iq + 3), truth.qz, 1e-5) << r;
    EXPECT_EQ(static_cast<int64_t>(cam->UInt64Value(r, *iut)), (in.camera_events[r].t_ns + 500) / 1000);
    EXPECT_EQ(cam->IntValue(r, *ir), 1);
  }
}

TEST(UlogWriter, DetectedAsUlog) {
  const auto path =
      std::filesystem::temp_directory_path() / ("ulog_writer_test_" + std::to_string(::getpid()) + ".ulg");
  UlogWriteOptions o;
  o.geoid_height_m = kGeoidM;
  WriteUlogTrack(path, TestTrack(), o);
  EXPECT_EQ(DetectFlightLogFormat(path), "px4-ulog");
  EXPECT_EQ(ReadFlightLog(path).camera_events.size(), 20u);
  std::filesystem::remove(path);
}

TEST(UlogWriter, BootTimeTrack) {
  FlightTrack in = TestTrack();
  in.time_base = TimeBase::kBoot;
  for (auto& f : in.fixes) f.t_ns -= kT0 - 5'000'000'000LL;
  for (auto& a : in.attitude) a.t_ns -= kT0 - 5'000'000'000LL;
  for (auto& e : in.camera_events) e.t_ns -= kT0 - 5'000'000'000LL;
  UlogWriteOptions o;
  o.geoid_height_m = kGeoidM;
  const FlightTrack out = RoundTrip(in, o);
  EXPECT_EQ(out.time_base, TimeBase::kBoot);
  ASSERT_EQ(out.fixes.size(), in.fixes.size());
  EXPECT_LE(std::llabs(out.fixes[7].t_ns - in.fixes[7].t_ns), 500);
  ASSERT_EQ(out.camera_events.size(), in.camera_events.size());
  EXPECT_LE(std::llabs(out.camera_events[3].t_ns - in.camera_events[3].t_ns), 500);
}

TEST(UlogWriter, UnknownFieldsLeftOut) {
  FlightTrack in = TestTrack();
  for (auto& f : in.fixes) f.alt_ref = AltitudeReference::kAmsl;
  for (auto& e : in.camera_events) e.alt_ref = AltitudeReference::kAmsl;
  in.fixes[3].satellites = -1;
  in.camera_events[2].sequence = -1;
  std::string bytes;
  const FlightTrack out = RoundTrip(in, {}, &bytes);  // AMSL track: no geoid height needed
  ASSERT_EQ(out.fixes.size(), in.fixes.size());
  EXPECT_EQ(out.fixes[0].satellites, -1);  // not written as 0
  EXPECT_EQ(out.camera_events[0].sequence, -1);
  EXPECT_NEAR(out.fixes[9].alt_m, in.fixes[9].alt_m, 0.5e-3 + 1e-9);
  std::istringstream is(bytes);
  const ulog::UlogFile log = ulog::ReadUlogFile(is, "mem.ulg");
  EXPECT_FALSE(log.FindTopic("vehicle_gps_position")->FieldIndex("alt_ellipsoid"));
}

TEST(UlogWriter, EllipsoidalWithoutGeoid) {
  std::stringstream ss;
  EXPECT_THROW(WriteUlogTrack(ss, TestTrack()), std::invalid_argument);
}

TEST(UlogWriter, InvalidPosition) {
  FlightTrack in = TestTrack();
  in.fixes[5].lat_deg = kNaN;
  UlogWriteOptions o;
  o.geoid_height_m = kGeoidM;
  std::stringstream ss;
  EXPECT_THROW(WriteUlogTrack(ss, in, o), std::invalid_argument);
}

}  // namespace
}  // namespace rs
