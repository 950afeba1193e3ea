#include "formats/flight_log/ulog/ulog_track.h"
#include "tests/support/test_data.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "formats/flight_log/ulog/ulog_test_builder.h"

namespace rs {
namespace {

using ulog::testing::Bytes;
using ulog::testing::UlogBuilder;

std::filesystem::path Sample(const char* name) { return rs::test::DataRoot() / "px4_ulog" / "test" / name; }

double DistanceM(const GnssFix& a, const GnssFix& b) {
  const double k = 6371000.0 * M_PI / 180.0;
  return std::hypot((b.lat_deg - a.lat_deg) * k, (b.lon_deg - a.lon_deg) * k * std::cos(a.lat_deg * M_PI / 180.0));
}

constexpr int64_t kUtcOffsetUs = 1618990000000000;  // boot 0 = 2021-04-21 07:26:40 UTC

std::string Synthetic(bool euler_attitude) {
  UlogBuilder b(100);
  b.Format(
      "vehicle_gps_position:uint64_t timestamp;uint64_t time_utc_usec;int32_t lat;int32_t lon;int32_t alt;"
      "int32_t alt_ellipsoid;float eph;float epv;float vel_m_s;uint8_t fix_type;uint8_t satellites_used;"
      "uint8_t[2] _padding0;");
  if (euler_attitude) {
    b.Format("vehicle_attitude:uint64_t timestamp;float roll;float pitch;float yaw;");
  } else {
    b.Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  }
  b.Format("camera_capture:uint64_t timestamp;uint32_t seq;double lat;double lon;float alt;");
  b.Subscribe(0, 1, "vehicle_gps_position").Subscribe(0, 2, "vehicle_attitude").Subscribe(0, 3, "camera_capture");
  for (int k = 0; k < 5; ++k) {
    const uint64_t t = 1000000 + k * 200000;
    // Record 0 has no fix and no UTC time yet.
    b.Data(1, Bytes()
                  .Put<uint64_t>(t)
                  .Put<uint64_t>(k == 0 ? 0 : t + kUtcOffsetUs - 150)  // fix epoch 150 us before publication
                  .Put<int32_t>(634170000 + k * 10)
                  .Put<int32_t>(104080000)
                  .Put<int32_t>(66814)
                  .Put<int32_t>(106766)
                  .Put<float>(1.5f)
                  .Put<float>(2.5f)
                  .Put<float>(0.5f)
                  .Put<uint8_t>(k == 0 ? 1 : 3)
                  .Put<uint8_t>(15)
                  .str());
    if (euler_attitude) {
      b.Data(2,
             Bytes().Put<uint64_t>(t + 10).Put<float>(0).Put<float>(0).Put<float>(static_cast<float>(M_PI / 2)).str());
    } else {
      b.Data(2,
             Bytes().Put<uint64_t>(t + 10).Put<float>(0.5f).Put<float>(0.5f).Put<float>(0.5f).Put<float>(0.5f).str());
    }
  }
  b.Data(
      3,
      Bytes().Put<uint64_t>(1300000).Put<uint32_t>(42).Put<double>(63.417).Put<double>(10.408).Put<float>(70.f).str());
  return b.str();
}

TEST(UlogTrack, Nominal) {
  std::istringstream in(Synthetic(false));
  const FlightTrack t = ReadUlogTrack(in, "syn.ulg");
  EXPECT_EQ(t.format, "px4-ulog");
  ASSERT_EQ(t.time_base, TimeBase::kUtc);
  ASSERT_EQ(t.fixes.size(), 4u);  // the no-fix record is dropped (and noted)
  EXPECT_EQ(t.fixes[0].t_ns, (1200000 + kUtcOffsetUs - 150) * 1000);
  EXPECT_NEAR(t.fixes[0].lat_deg, 63.417001, 1e-9);
  EXPECT_NEAR(t.fixes[0].lon_deg, 10.408, 1e-9);
  EXPECT_NEAR(t.fixes[0].alt_m, 66.814, 1e-9);
  EXPECT_EQ(t.fixes[0].alt_ref, AltitudeReference::kAmsl);
  EXPECT_EQ(t.fixes[0].fix_type, 3);
  EXPECT_EQ(t.fixes[0].satellites, 15);
  EXPECT_NEAR(t.fixes[0].h_acc_m, 1.5, 1e-6);
  EXPECT_NEAR(t.fixes[0].v_acc_m, 2.5, 1e-6);
  EXPECT_NEAR(t.fixes[0].ground_speed_m_s, 0.5, 1e-6);
  ASSERT_EQ(t.attitude.size(), 5u);
  EXPECT_EQ(t.attitude[0].t_ns, (1000010 + kUtcOffsetUs - 150) * 1000);
  EXPECT_NEAR(t.attitude[0].qw, 0.5, 1e-7);
  EXPECT_NEAR(t.attitude[0].qz, 0.5, 1e-7);
  ASSERT_EQ(t.camera_events.size(), 1u);
  EXPECT_EQ(t.camera_events[0].sequence, 42);
  EXPECT_EQ(t.camera_events[0].t_ns, (1300000 + kUtcOffsetUs - 150) * 1000);
  EXPECT_DOUBLE_EQ(t.camera_events[0].lat_deg, 63.417);
  EXPECT_NEAR(t.camera_events[0].alt_m, 70.0, 1e-6);
  bool noted = false;
  for (const std::string& n : t.notes) noted = noted || n.find("dropped 1 of 5") != std::string::npos;
  EXPECT_TRUE(noted);
}

TEST(UlogTrack, EulerAttitude) {
  std::istringstream in(Synthetic(true));
  const FlightTrack t = ReadUlogTrack(in, "syn.ulg");
  ASSERT_EQ(t.attitude.size(), 5u);
  // yaw 90 deg: rotation about NED down by +90 deg.
  EXPECT_NEAR(t.attitude[0].qw, std::sqrt(0.5), 1e-7);
  EXPECT_NEAR(t.attitude[0].qz, std::sqrt(0.5), 1e-7);
  EXPECT_NEAR(t.attitude[0].qx, 0, 1e-7);
}

TEST(UlogTrack, SampleLogSmall) {
  const auto p = Sample("sample_log_small.ulg");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << "sample data absent: " << p;
  const ulog::UlogFile log = ulog::ReadUlogFile(p);
  const FlightTrack t = UlogToFlightTrack(log, p.string());
  ASSERT_EQ(t.time_base, TimeBase::kUtc);
  ASSERT_EQ(t.fixes.size(), 32u);  // README: 32 fixes at ~63.417 N 10.408 E
  const ulog::Topic* gps = log.FindTopic("vehicle_gps_position");
  const size_t iutc = *gps->FieldIndex("time_utc_usec"), iell = *gps->FieldIndex("alt_ellipsoid");
  for (size_t i = 0; i < t.fixes.size(); ++i) {
    const GnssFix& f = t.fixes[i];
    EXPECT_NEAR(f.lat_deg, 63.417, 0.01);
    EXPECT_NEAR(f.lon_deg, 10.408, 0.01);
    EXPECT_EQ(f.fix_type, 3);
    EXPECT_GE(f.satellites, 6);
    // Each fix's mapped time agrees with its own GNSS UTC time (publication latency < 0.5 s).
    EXPECT_NEAR(f.t_ns * 1e-9, gps->UInt64Value(i, iutc) * 1e-6, 0.5);
    // AMSL vs ellipsoid: the geoid lies ~40 m above the ellipsoid at Trondheim.
    EXPECT_NEAR(gps->IntValue(i, iell) * 1e-3 - f.alt_m, 40.0, 3.0);
    EXPECT_GT(f.alt_m, 0);
    EXPECT_LT(f.alt_m, 200);
    if (i > 0) {
      ASSERT_GT(t.fixes[i].t_ns, t.fixes[i - 1].t_ns);
      EXPECT_LT(DistanceM(t.fixes[i - 1], f) / ((f.t_ns - t.fixes[i - 1].t_ns) * 1e-9), 30.0);
    }
  }
  EXPECT_EQ(t.attitude.size(), log.FindTopic("vehicle_attitude")->size());
  for (const AttitudeSample& a : t.attitude)
    EXPECT_NEAR(a.qw * a.qw + a.qx * a.qx + a.qy * a.qy + a.qz * a.qz, 1, 1e-9);
}

TEST(UlogTrack, SampleWithoutGps) {
  const auto p = Sample("sample.ulg");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << "sample data absent: " << p;
  const FlightTrack t = ReadUlogTrack(p);
  EXPECT_EQ(t.time_base, TimeBase::kBoot);
  EXPECT_TRUE(t.fixes.empty());
  EXPECT_EQ(t.attitude.size(), 6461u);
  EXPECT_EQ(t.attitude.front().t_ns % 1000, 0);
  bool noted = false;
  for (const std::string& n : t.notes) noted = noted || n.find("no GPS UTC time") != std::string::npos;
  EXPECT_TRUE(noted);
}

TEST(UlogTrack, SampleDoubleLatLon) {
  // Newer PX4: latitude_deg/longitude_deg/altitude_msl_m as doubles (SITL at Zurich).
  const auto p = Sample("sample_px4_events.ulg");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << "sample data absent: " << p;
  const FlightTrack t = ReadUlogTrack(p);
  ASSERT_EQ(t.time_base, TimeBase::kUtc);
  ASSERT_GT(t.fixes.size(), 400u);  // 583 records, the first ones before the simulated GPS has a fix
  for (const GnssFix& f : t.fixes) {
    EXPECT_NEAR(f.lat_deg, 47.3977, 0.01);
    EXPECT_NEAR(f.lon_deg, 8.5456, 0.01);
    EXPECT_NEAR(f.alt_m, 490, 20);
  }
  // 2024-03-18 (the log file name's date), 14:49 UTC.
  EXPECT_NEAR(t.fixes.front().t_ns * 1e-9, 1710773350.0, 120.0);
}

// A log cut short (power loss) reads up to its last complete message, with a note saying how much
// was read: exactly what a file ending at that message boundary holds, never an error.
TEST(UlogTrack, CutShortSampleReadsToLastCompleteMessage) {
  const auto p = Sample("sample_px4_events.ulg");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << "sample data absent: " << p;
  std::ifstream in(p, std::ios::binary);
  const std::string full(std::istreambuf_iterator<char>(in), {});
  const auto read_track = [](const std::string& bytes) {
    std::istringstream ss(bytes);
    return ReadUlogTrack(ss, "cut.ulg");
  };
  const FlightTrack whole = read_track(full);
  size_t previous_fixes = 0;
  for (const double fraction : {0.1, 0.25, 0.5, 0.75, 0.9, 0.99}) {
    const size_t len = static_cast<size_t>(fraction * full.size());
    const std::string cut = full.substr(0, len);
    std::istringstream ss(cut);
    const ulog::UlogFile file = ulog::ReadUlogFile(ss, "cut.ulg", kFlightLogReadOptions);
    ASSERT_TRUE(file.cut.has_value()) << "a cut inside a message at byte " << len;
    EXPECT_EQ(file.cut->file_bytes, static_cast<int64_t>(len));
    ASSERT_LT(file.cut->offset, static_cast<int64_t>(len));
    // What was read equals a file that ends at the last complete message, read strictly.
    std::istringstream at_boundary(full.substr(0, static_cast<size_t>(file.cut->offset)));
    const ulog::UlogFile strict = ulog::ReadUlogFile(at_boundary, "boundary.ulg");
    ASSERT_EQ(strict.topics.size(), file.topics.size());
    for (size_t i = 0; i < strict.topics.size(); ++i) EXPECT_EQ(strict.topics[i].records, file.topics[i].records);

    const FlightTrack t = read_track(cut);
    const std::string expected =
        fmt::format("read {} of {} bytes, {} complete messages", file.cut->offset, len, file.cut->messages_read);
    bool noted = false;
    for (const std::string& n : t.notes) noted = noted || n.find(expected) != std::string::npos;
    EXPECT_TRUE(noted) << "no note '" << expected << "' at cut " << len;
    // The fixes read are the whole log's first ones.
    EXPECT_GE(t.fixes.size(), previous_fixes);
    ASSERT_LE(t.fixes.size(), whole.fixes.size());
    for (size_t i = 0; i < t.fixes.size(); ++i) {
      EXPECT_EQ(t.fixes[i].lat_deg, whole.fixes[i].lat_deg) << i;
      EXPECT_EQ(t.fixes[i].lon_deg, whole.fixes[i].lon_deg) << i;
    }
    previous_fixes = t.fixes.size();
  }
  EXPECT_GT(previous_fixes, 0u);
}

}  // namespace
}  // namespace rs
