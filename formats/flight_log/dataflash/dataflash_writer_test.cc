#include "formats/flight_log/dataflash/dataflash_writer.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "formats/flight_log/dataflash/dataflash_file.h"
#include "formats/flight_log/dataflash/dataflash_track.h"
#include "formats/flight_log/dataflash/gps_time.h"
#include "formats/flight_log/flight_log.h"
#include "formats/flight_log/writer_test_attitude.h"

namespace rs {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGeoidM = 47.25;
// 2023-11-14T22:13:20.000123456Z: deliberately not on a millisecond.
constexpr int64_t kT0 = 1'700'000'000'000'123'456LL;
constexpr int64_t kMs = 1'000'000;

// Truth attitude: roll/pitch oscillate, yaw turns through 360 deg several times.
AttitudeSample TruthAttitude(int64_t t_ns) { return test::TruthAttitudeAt(t_ns, (t_ns - kT0) * 1e-9); }
// Rotation angle between two unit quaternions, degrees.
double AngleDeg(const AttitudeSample& a, const AttitudeSample& b) {
  const double d = std::fabs(a.qw * b.qw + a.qx * b.qx + a.qy * b.qy + a.qz * b.qz);
  return 2 * std::acos(std::min(1.0, d)) * 180 / kPi;
}

// 30 s: fixes at 5 Hz (ellipsoidal heights), attitude at 50 Hz, 20 camera events between samples.
FlightTrack TestTrack() {
  FlightTrack t;
  t.format = "csv";
  t.time_base = TimeBase::kUtc;
  for (int k = 0; k < 150; ++k) {
    GnssFix f;
    f.t_ns = kT0 + k * 200'000'000LL;
    f.lat_deg = 46.0569 + 1.234567e-6 * k;
    f.lon_deg = -122.3 - 0.7654321e-6 * k;
    f.alt_m = 300.0 + 0.01234 * k;
    f.alt_ref = AltitudeReference::kEllipsoid;
    f.fix_type = k % 2 ? 6 : 3;
    f.satellites = 10 + k % 7;
    f.ground_speed_m_s = 4.2 + 0.01 * k;
    t.fixes.push_back(f);
  }
  for (int k = 0; k < 1500; ++k) t.attitude.push_back(TruthAttitude(kT0 + k * 20'000'000LL));
  for (int k = 0; k < 20; ++k) {
    CameraEvent e;
    e.t_ns = kT0 + 1'000'000'000LL + k * 1'000'000'000LL + 7'777'777;
    e.sequence = 100 + k;
    e.lat_deg = 46.0569 + 1e-5 * k;
    e.lon_deg = 14.5058 + 2e-5 * k;
    e.alt_m = 310.5 + 0.123 * k;
    e.alt_ref = AltitudeReference::kEllipsoid;
    t.camera_events.push_back(e);
  }
  return t;
}

DataflashWriteOptions Geoid() {
  DataflashWriteOptions o;
  o.geoid_height_m = kGeoidM;
  return o;
}

TEST(DataflashWriter, Nominal) {
  const FlightTrack in = TestTrack();
  std::stringstream ss;
  WriteDataflashTrack(ss, in, Geoid());
  const std::string bytes = ss.str();
  const FlightTrack out = ReadDataflashTrack(ss, "mem.bin");
  EXPECT_EQ(out.time_base, TimeBase::kUtc);
  ASSERT_EQ(out.fixes.size(), in.fixes.size());
  int64_t max_dt = 0;
  for (size_t i = 0; i < in.fixes.size(); ++i) {
    const GnssFix &a = in.fixes[i], &b = out.fixes[i];
    max_dt = std::max<int64_t>(max_dt, std::llabs(a.t_ns - b.t_ns));
    EXPECT_LE(std::llabs(a.t_ns - b.t_ns), kMs / 2) << i;  // GPS ms of week
    EXPECT_NEAR(b.lat_deg, a.lat_deg, 0.5e-7 + 1e-12) << i;
    EXPECT_NEAR(b.lon_deg, a.lon_deg, 0.5e-7 + 1e-12) << i;
    EXPECT_NEAR(b.alt_m, a.alt_m - kGeoidM, 0.5e-2 + 1e-9) << i;  // cm
    EXPECT_EQ(b.alt_ref, AltitudeReference::kAmsl);
    EXPECT_EQ(b.fix_type, a.fix_type);
    EXPECT_EQ(b.satellites, a.satellites);
    EXPECT_NEAR(b.ground_speed_m_s, a.ground_speed_m_s, 1e-6);
  }
  ASSERT_EQ(out.attitude.size(), in.attitude.size());
  double max_angle = 0;
  for (size_t i = 0; i < in.attitude.size(); ++i) {
    const AttitudeSample &a = in.attitude[i], &b = out.attitude[i];
    EXPECT_LE(std::llabs(a.t_ns - b.t_ns), kMs) << i;  // boot clock mapped through the GPS-ms fit
    // Three angles rounded to 0.01 deg: at most 0.005 deg each.
    max_angle = std::max(max_angle, AngleDeg(a, b));
    EXPECT_LT(AngleDeg(a, b), 0.0087) << i;
  }
  ASSERT_EQ(out.camera_events.size(), in.camera_events.size());
  for (size_t i = 0; i < in.camera_events.size(); ++i) {
    const CameraEvent &a = in.camera_events[i], &b = out.camera_events[i];
    EXPECT_LE(std::llabs(a.t_ns - b.t_ns), kMs) << i;
    EXPECT_EQ(b.sequence, a.sequence);
    EXPECT_NEAR(b.lat_deg, a.lat_deg, 0.5e-7 + 1e-12);
    EXPECT_NEAR(b.lon_deg, a.lon_deg, 0.5e-7 + 1e-12);
    EXPECT_NEAR(b.alt_m, a.alt_m - kGeoidM, 0.5e-2 + 1e-9);
    EXPECT_EQ(b.alt_ref, AltitudeReference::kAmsl);
  }
  std::printf("max fix time error %lld ns, max attitude error %.5f deg\n", static_cast<long long>(max_dt), max_angle);

  // Fields the track reader does not take: CAM GPS time and attitude, boot times.
  std::istringstream is(bytes);
  const dataflash::DataflashFile log = dataflash::ReadDataflashFile(is, "mem.bin");
  EXPECT_EQ(log.skipped_bytes, 0);
  EXPECT_EQ(log.rejected_formats, 0);
  const dataflash::MessageType* cam = log.Find("CAM");
  ASSERT_NE(cam, nullptr);
  const auto gt = cam->ColumnIndex("GPSTime"), gw = cam->ColumnIndex("GPSWeek"), r = cam->ColumnIndex("R"),
             p = cam->ColumnIndex("P"), y = cam->ColumnIndex("Y"), tu = cam->ColumnIndex("TimeUS");
  ASSERT_TRUE(gt && gw && r && p && y && tu);
  for (size_t i = 0; i < cam->size(); ++i) {
    const int64_t t = in.camera_events[i].t_ns;
    const auto utc = dataflash::GpsWeekMsToUtcNs(cam->Int(i, *gw), cam->Int(i, *gt));
    ASSERT_TRUE(utc);
    EXPECT_LE(std::llabs(*utc - t), kMs / 2);
    EXPECT_EQ(cam->Int(i, *tu), 1'000'000 + (t - kT0 + 500) / 1000);  // boot clock starts at 1 s
    double rr, pp, yy;
    test::TruthEulerRad((t - kT0) * 1e-9, &rr, &pp, &yy);
    // Interpolated between 50 Hz samples (error < 0.001 deg) then rounded to 0.01 deg.
    EXPECT_NEAR(cam->Value(i, *r), rr * 180 / kPi, 0.006) << i;
    EXPECT_NEAR(cam->Value(i, *p), pp * 180 / kPi, 0.006) << i;
    EXPECT_NEAR(cam->Value(i, *y), yy * 180 / kPi, 0.006) << i;
  }
}

TEST(DataflashWriter, GpsWeekMs) {
  // 2023-11-14T22:13:20Z: GPS week 2288 began Sunday 2023-11-12; +2 d 22:13:20 +18 s leap.
  const dataflash::GpsWeekMs g = dataflash::UtcNsToGpsWeekMs(1'700'000'000'000'000'000LL);
  EXPECT_EQ(g.week, 2288);
  EXPECT_EQ(g.ms, (2 * 86400 + 22 * 3600 + 13 * 60 + 20 + 18) * 1000LL);
  // Round trip across leap-second eras (2014: 16 s, 2016: 17 s, 2024: 18 s), just after a leap and mid-week.
  for (int64_t utc_s : {1400000000LL, 1435708800LL, 1460000000LL, 1483228800LL, 1720000000LL}) {
    const int64_t t = utc_s * 1'000'000'000LL + 123'000'000;
    const dataflash::GpsWeekMs w = dataflash::UtcNsToGpsWeekMs(t);
    EXPECT_EQ(dataflash::GpsWeekMsToUtcNs(w.week, w.ms), t) << utc_s;
  }
  EXPECT_THROW(dataflash::UtcNsToGpsWeekMs(0), std::invalid_argument);
}

TEST(DataflashWriter, DetectedAsDataflash) {
  const auto path =
      std::filesystem::temp_directory_path() / ("dataflash_writer_test_" + std::to_string(::getpid()) + ".bin");
  WriteDataflashTrack(path, TestTrack(), Geoid());
  EXPECT_EQ(DetectFlightLogFormat(path), "ardupilot-dataflash");
  EXPECT_EQ(ReadFlightLog(path).fixes.size(), 150u);
  std::filesystem::remove(path);
}

TEST(DataflashWriter, BootTimeTrack) {
  FlightTrack in = TestTrack();
  in.time_base = TimeBase::kBoot;
  const int64_t shift = kT0 - 5'000'000'000LL;
  for (auto& f : in.fixes) f.t_ns -= shift;
  for (auto& a : in.attitude) a.t_ns -= shift;
  for (auto& e : in.camera_events) e.t_ns -= shift;
  std::stringstream ss;
  WriteDataflashTrack(ss, in, Geoid());
  const FlightTrack out = ReadDataflashTrack(ss, "mem.bin");
  EXPECT_EQ(out.time_base, TimeBase::kBoot);
  ASSERT_EQ(out.fixes.size(), in.fixes.size());
  EXPECT_LE(std::llabs(out.fixes[7].t_ns - in.fixes[7].t_ns), 500);
  ASSERT_EQ(out.camera_events.size(), in.camera_events.size());
  EXPECT_LE(std::llabs(out.camera_events[3].t_ns - in.camera_events[3].t_ns), 500);
}

TEST(DataflashWriter, UnknownFieldsLeftOut) {
  FlightTrack in = TestTrack();
  in.fixes[3].satellites = -1;
  in.camera_events[2].sequence = -1;
  in.camera_events[4].lat_deg = kNaN;
  in.camera_events.back().t_ns = in.attitude.back().t_ns + 1;  // beyond the attitude: no R/P/Y
  std::stringstream ss;
  WriteDataflashTrack(ss, in, Geoid());
  const std::string bytes = ss.str();
  const FlightTrack out = ReadDataflashTrack(ss, "mem.bin");
  ASSERT_EQ(out.fixes.size(), in.fixes.size());
  EXPECT_EQ(out.fixes[0].satellites, -1);  // not written as 0
  ASSERT_EQ(out.camera_events.size(), in.camera_events.size());
  EXPECT_EQ(out.camera_events[0].sequence, -1);
  EXPECT_TRUE(std::isnan(out.camera_events[0].lat_deg));
  EXPECT_NEAR(out.camera_events[0].alt_m, in.camera_events[0].alt_m - kGeoidM, 0.5e-2 + 1e-9);
  std::istringstream is(bytes);
  const dataflash::DataflashFile log = dataflash::ReadDataflashFile(is, "mem.bin");
  EXPECT_FALSE(log.Find("CAM")->ColumnIndex("R"));
  EXPECT_FALSE(log.Find("GPS")->ColumnIndex("NSats"));
}

TEST(DataflashWriter, EllipsoidalWithoutGeoid) {
  std::stringstream ss;
  EXPECT_THROW(WriteDataflashTrack(ss, TestTrack()), std::invalid_argument);
}

TEST(DataflashWriter, InvalidPosition) {
  FlightTrack in = TestTrack();
  in.fixes[5].lon_deg = 181;
  std::stringstream ss;
  EXPECT_THROW(WriteDataflashTrack(ss, in, Geoid()), std::invalid_argument);
}

}  // namespace
}  // namespace rs
