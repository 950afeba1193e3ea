#include "formats/flight_log/dataflash/dataflash_track.h"
#include "tests/support/test_data.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "formats/flight_log/dataflash/dataflash_test_builder.h"
#include "formats/flight_log/dataflash/gps_time.h"
#include "formats/input_error.h"

namespace rs {
namespace {

using dataflash::testing::DataflashBuilder;
using dataflash::testing::Payload;

std::filesystem::path DataDir() { return rs::test::DataRoot() / "ardupilot_dataflash"; }

double DistanceM(const GnssFix& a, const GnssFix& b) {
  // Equirectangular approximation: exact enough over a few metres.
  const double k = 6371000.0 * M_PI / 180.0;
  const double dn = (b.lat_deg - a.lat_deg) * k;
  const double de = (b.lon_deg - a.lon_deg) * k * std::cos(a.lat_deg * M_PI / 180.0);
  return std::hypot(dn, de);
}

// New-style (2016+) messages: GPS with an instance column, ATT, CAM.
DataflashBuilder SyntheticLog() {
  DataflashBuilder b;
  b.Fmt(130, 3 + 8 + 1 + 1 + 4 + 2 + 1 + 2 + 4 + 4 + 4 + 4, "GPS", "QBBIHBcLLff",
        "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd");
  b.Fmt(131, 3 + 8 + 2 + 2 + 2 + 2 + 2 + 2, "ATT", "QccccCC", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw");
  b.Fmt(132, 3 + 8 + 1 + 2 + 4 + 2 + 4 + 4 + 4 + 4 + 4 + 4, "CAM", "QBHIHLLefff",
        "TimeUS,I,Img,GPSTime,GPSWeek,Lat,Lng,Alt,RelAlt,GPSAlt,R");
  for (int k = 0; k < 10; ++k) {
    const uint64_t boot_us = 5000000 + k * 200000ull;  // 5 Hz
    for (uint8_t inst : {0, 1}) {
      b.Message(130, Payload()
                         .Put<uint64_t>(boot_us)
                         .Put<uint8_t>(inst)
                         .Put<uint8_t>(k == 0 ? 1 : 3)  // first record: no fix
                         .Put<uint32_t>(static_cast<uint32_t>(388800000 + k * 200))
                         .Put<uint16_t>(2086)
                         .Put<uint8_t>(12)
                         .Put<int16_t>(80)
                         .Put<int32_t>(428500000 + k * 10 + inst * 100000)  // instance 1 is 1.1 km off
                         .Put<int32_t>(-26800000)
                         .Put<float>(520.5f)
                         .Put<float>(0.5f)
                         .str());
    }
    b.Message(131, Payload()
                       .Put<uint64_t>(boot_us + 1000)
                       .Put<int16_t>(0)
                       .Put<int16_t>(0)
                       .Put<int16_t>(0)
                       .Put<int16_t>(0)
                       .Put<uint16_t>(0)
                       .Put<uint16_t>(9000)
                       .str());
  }
  b.Message(132, Payload()
                     .Put<uint64_t>(5500000)
                     .Put<uint8_t>(0)
                     .Put<uint16_t>(17)
                     .Put<uint32_t>(0)
                     .Put<uint16_t>(0)
                     .Put<int32_t>(428500050)
                     .Put<int32_t>(-26800000)
                     .Put<int32_t>(52300)
                     .Put<float>(30.f)
                     .Put<float>(521.f)
                     .Put<float>(0)
                     .str());
  return b;
}

TEST(DataflashTrack, Nominal) {
  std::istringstream in(SyntheticLog().str());
  const FlightTrack t = ReadDataflashTrack(in, "syn.bin");
  EXPECT_EQ(t.format, "ardupilot-dataflash");
  ASSERT_EQ(t.time_base, TimeBase::kUtc);
  ASSERT_EQ(t.fixes.size(), 9u);  // instance 0 only, the no-fix record dropped
  // boot 5.2 s <-> GPS week 2086, 388800.2 s (exactly, so the offset is exact).
  const int64_t utc0 = *dataflash::GpsWeekMsToUtcNs(2086, 388800200);
  EXPECT_EQ(t.fixes[0].t_ns, utc0);
  EXPECT_EQ(t.fixes[8].t_ns - t.fixes[0].t_ns, 1600000000);
  EXPECT_NEAR(t.fixes[0].lat_deg, 42.850001, 1e-9);
  EXPECT_NEAR(t.fixes[0].lon_deg, -2.68, 1e-9);
  EXPECT_NEAR(t.fixes[0].alt_m, 520.5, 1e-6);
  EXPECT_EQ(t.fixes[0].alt_ref, AltitudeReference::kAmsl);
  EXPECT_EQ(t.fixes[0].fix_type, 3);
  EXPECT_EQ(t.fixes[0].satellites, 12);
  EXPECT_NEAR(t.fixes[0].ground_speed_m_s, 0.5, 1e-6);
  // Yaw 90 deg: body x (forward) points east.
  ASSERT_EQ(t.attitude.size(), 10u);
  EXPECT_NEAR(t.attitude[0].qw, std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(t.attitude[0].qz, std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(t.attitude[0].qx, 0, 1e-12);
  EXPECT_EQ(t.attitude[1].t_ns, utc0 + 1000000);
  ASSERT_EQ(t.camera_events.size(), 1u);
  EXPECT_EQ(t.camera_events[0].sequence, 17);
  EXPECT_EQ(t.camera_events[0].t_ns, utc0 + 300000000);
  EXPECT_NEAR(t.camera_events[0].lat_deg, 42.850005, 1e-9);
  EXPECT_NEAR(t.camera_events[0].alt_m, 521.0, 1e-6);
  EXPECT_EQ(t.camera_events[0].alt_ref, AltitudeReference::kAmsl);
}

TEST(DataflashTrack, NoGpsTimeGivesBootTime) {
  DataflashBuilder b;
  b.Fmt(131, 3 + 4 + 2 + 2 + 2, "ATT", "IccC", "TimeMS,Roll,Pitch,Yaw");
  b.Message(131, Payload().Put<uint32_t>(1234).Put<int16_t>(0).Put<int16_t>(0).Put<uint16_t>(0).str());
  std::istringstream in(b.str());
  const FlightTrack t = ReadDataflashTrack(in, "att.bin");
  EXPECT_EQ(t.time_base, TimeBase::kBoot);
  ASSERT_EQ(t.attitude.size(), 1u);
  EXPECT_EQ(t.attitude[0].t_ns, 1234000000);
  EXPECT_FALSE(t.notes.empty());
}

struct Sample {
  const char* path;
  int fixes_3d;  // README.txt: GPS Status >= 3 fixes
  int day, month, year;
};

class DataflashSamples : public ::testing::TestWithParam<Sample> {};

TEST_P(DataflashSamples, Nominal) {
  const Sample s = GetParam();
  const auto p = DataDir() / s.path;
  if (!std::filesystem::exists(p)) GTEST_SKIP() << "sample data absent: " << p;
  const dataflash::DataflashFile log = dataflash::ReadDataflashFile(p);
  const FlightTrack t = DataflashToFlightTrack(log, p.string());
  ASSERT_EQ(t.time_base, TimeBase::kUtc);
  // README counts GPS records with Status >= 3 (the track drops repeats of a GPS time, checked below).
  const dataflash::MessageType* g = log.Find("GPS");
  int n3d = 0;
  for (size_t r = 0; r < g->size(); ++r) n3d += g->Int(r, *g->ColumnIndex("Status")) >= 3;
  EXPECT_EQ(n3d, s.fixes_3d);
  // README: Basque Country, ~42.85 N -2.68 E (tolerance 0.05 deg, ~5 km); field altitude ~500 m AMSL.
  for (const GnssFix& f : t.fixes) {
    if (f.fix_type < 3) continue;
    EXPECT_NEAR(f.lat_deg, 42.85, 0.05);
    EXPECT_NEAR(f.lon_deg, -2.68, 0.05);
    EXPECT_GT(f.alt_m, 400);
    EXPECT_LT(f.alt_m, 800);
    EXPECT_EQ(f.alt_ref, AltitudeReference::kAmsl);
  }
  // The flight date in the folder name is the UTC date of the first fix.
  const std::time_t secs = static_cast<std::time_t>(t.fixes.front().t_ns / 1000000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  EXPECT_EQ(tm.tm_mday, s.day);
  EXPECT_EQ(tm.tm_mon + 1, s.month);
  EXPECT_EQ(tm.tm_year + 1900, s.year);
  // Plausible motion: under 40 m/s between 3D fixes at least 0.15 s apart.
  const GnssFix* prev = nullptr;
  for (const GnssFix& f : t.fixes) {
    if (f.fix_type < 3) continue;
    if (prev && f.t_ns - prev->t_ns >= 150000000) {
      EXPECT_LT(DistanceM(*prev, f) / ((f.t_ns - prev->t_ns) * 1e-9), 40.0);
    }
    prev = &f;
  }
  // In file order both GPS clocks are monotonic. Each fix carries its own GPS
  // time; records re-logging the previous GPS time are dropped. Boot time maps
  // to UTC within 0.5 s of every fresh GPS time (these PXF boards' boot clock
  // runs ~8 % slow against GPS time, so this needs a rate, not an offset).
  const dataflash::MessageType* gps = log.Find("GPS");
  ASSERT_NE(gps, nullptr);
  const auto clock = dataflash::FitBootClock(log);
  ASSERT_TRUE(clock.has_value());
  EXPECT_GT(clock->rate, 0.9);
  EXPECT_LT(clock->rate, 1.1);
  const size_t st = *gps->ColumnIndex("Status"), wk = *gps->ColumnIndex("Week"), ms = *gps->ColumnIndex("TimeMS"),
               boot = *gps->ColumnIndex("T");
  int64_t last_utc = 0, last_boot = 0;
  size_t i = 0;
  double max_err_s = 0;
  for (size_t r = 0; r < gps->size(); ++r) {
    if (gps->Int(r, st) < 2) continue;
    const int64_t utc = *dataflash::GpsWeekMsToUtcNs(gps->Int(r, wk), gps->Int(r, ms));
    const int64_t b = gps->Int(r, boot) * 1000000;
    EXPECT_GE(utc, last_utc);
    EXPECT_GE(b, last_boot);
    if (utc != last_utc) {
      ASSERT_LT(i, t.fixes.size());
      EXPECT_EQ(t.fixes[i++].t_ns, utc);
      if (gps->Int(r, st) >= 3) max_err_s = std::max(max_err_s, std::fabs((clock->ToUtcNs(b) - utc) * 1e-9));
    }
    last_utc = utc;
    last_boot = b;
  }
  EXPECT_EQ(i, t.fixes.size());
  EXPECT_LT(max_err_s, 0.5);  // logging latency of a fresh fix reaches 0.4 s in Loiter_RTL.bin
  EXPECT_NEAR(clock->max_residual_s, max_err_s, 1e-6);
  // Attitude: one unit quaternion per ATT record.
  EXPECT_EQ(t.attitude.size(), log.Find("ATT")->size());
  for (const AttitudeSample& a : t.attitude)
    EXPECT_NEAR(a.qw * a.qw + a.qx * a.qx + a.qy * a.qy + a.qz * a.qz, 1, 1e-9);
}

TEST_P(DataflashSamples, TruncatedAndBitFlipped) {
  const auto p = DataDir() / GetParam().path;
  if (!std::filesystem::exists(p)) GTEST_SKIP() << "sample data absent: " << p;
  std::ifstream in(p, std::ios::binary);
  const std::string full(std::istreambuf_iterator<char>(in), {});
  const dataflash::DataflashFile ref = dataflash::ReadDataflashFile(p);
  size_t ref_records = 0;
  for (const auto& m : ref.types) ref_records += m.size();

  // Truncated anywhere: the cut message is a counted skip at its own offset.
  std::mt19937_64 rng(99);
  for (int k = 0; k < 4; ++k) {
    const size_t len = 2000 + rng() % (full.size() - 2000);
    std::istringstream cut(full.substr(0, len));
    const dataflash::DataflashFile f = dataflash::ReadDataflashFile(cut, "cut.bin");
    ASSERT_FALSE(f.skips.empty());
    const dataflash::Skip& tail = f.skips.back();
    EXPECT_EQ(tail.offset + tail.bytes, static_cast<int64_t>(len));
    EXPECT_LT(tail.bytes, 256);  // at most one message
  }
  // Bit flips: never a crash; damage is a counted skip or a changed value.
  for (int k = 0; k < 8; ++k) {
    std::string flipped = full;
    for (int j = 0; j < 8; ++j) {
      const size_t at = rng() % full.size();
      flipped[at] = static_cast<char>(flipped[at] ^ (1 << (rng() % 8)));
    }
    std::istringstream fin(flipped);
    try {
      const FlightTrack t = ReadDataflashTrack(fin, "flipped.bin");
      EXPECT_LE(t.fixes.size(), ref.Find("GPS")->size() + 8);
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().byte_offset, 0);  // only when no FMT survived
    }
  }
  // A broken header byte of one GPS record: exactly that record is skipped, at its offset.
  const dataflash::MessageType* gps = ref.Find("GPS");
  const int64_t target = gps->offsets[gps->size() / 2];
  std::string broken = full;
  broken[static_cast<size_t>(target)] = '\x00';
  std::istringstream bin(broken);
  const dataflash::DataflashFile f = dataflash::ReadDataflashFile(bin, "broken.bin");
  EXPECT_EQ(f.Find("GPS")->size(), gps->size() - 1);
  EXPECT_EQ(f.skipped_bytes, ref.skipped_bytes + gps->length);
  bool found = false;
  for (const dataflash::Skip& s : f.skips) found = found || (s.offset == target && s.bytes == gps->length);
  EXPECT_TRUE(found);
}

INSTANTIATE_TEST_SUITE_P(Erle, DataflashSamples,
                         ::testing::Values(Sample{"pxf/copter/14-11-2014/118.BIN", 1309, 14, 11, 2014},
                                           Sample{"pxf/copter/5-12-2014/218.BIN", 1816, 5, 12, 2014},
                                           Sample{"pxf/copter/6-11-2014/Loiter_RTL.bin", 990, 6, 11, 2014},
                                           Sample{"pxf/plane/4-12-2014/329.BIN", 3290, 4, 12, 2014}),
                         [](const ::testing::TestParamInfo<Sample>& info) {
                           std::string n = std::filesystem::path(info.param.path).stem().string();
                           for (char& c : n) c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
                           return n;
                         });

}  // namespace
}  // namespace rs
