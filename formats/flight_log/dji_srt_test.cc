#include "formats/flight_log/dji_srt.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "formats/flight_log/sample_mutation.h"
#include "formats/input_error.h"

namespace rs {
namespace {

FlightTrack Read(const std::string& text) {
  std::istringstream in(text);
  return ReadDjiSrt(in, "v.srt");
}

bool HasNote(const FlightTrack& t, const std::string& part) {
  for (const std::string& n : t.notes)
    if (n.find(part) != std::string::npos) return true;
  return false;
}

void ExpectError(const std::string& text, int64_t line, int64_t column, const std::string& what) {
  try {
    Read(text);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, line) << e.what();
    if (column >= 0) {
      EXPECT_EQ(e.where().column, column) << e.what();
    }
    EXPECT_NE(e.message().find(what), std::string::npos) << e.what();
  }
}

TEST(DjiSrt, Nominal) {  // Mavic 3 dialect
  const FlightTrack t = Read(
      "1\n00:00:00,000 --> 00:00:00,020\n<font size=\"28\">FrameCnt: 1, DiffTime: 20ms\n2021-12-25 12:27:52.373\n"
      "[iso: 220] [shutter: 1/8000.0] [fnum: 3.2] [latitude: 46.051234] [longitude: 14.505678] [rel_alt: 12.500 "
      "abs_alt: 310.25] </font>\n\n"
      "2\n00:00:00,020 --> 00:00:00,040\n<font size=\"28\">FrameCnt: 2, DiffTime: 20ms\n2021-12-25 12:27:52.393\n"
      "[iso: 220] [latitude: 46.051240] [longitude: 14.505670] [rel_alt: 12.600 abs_alt: 310.35] </font>\n");
  EXPECT_EQ(t.format, "dji-srt");
  EXPECT_EQ(t.time_base, TimeBase::kBoot);
  ASSERT_EQ(t.fixes.size(), 2u);
  EXPECT_EQ(t.fixes[0].t_ns, 0);
  EXPECT_EQ(t.fixes[1].t_ns, 20000000);
  EXPECT_DOUBLE_EQ(t.fixes[0].lat_deg, 46.051234);
  EXPECT_DOUBLE_EQ(t.fixes[0].lon_deg, 14.505678);
  EXPECT_DOUBLE_EQ(t.fixes[1].alt_m, 310.35);
  EXPECT_EQ(t.fixes[1].alt_ref, AltitudeReference::kAmsl);
  EXPECT_TRUE(HasNote(t, "2021-12-25T12:27:52.373000000"));
}

TEST(DjiSrt, LonLatOrderByMagnitude) {  // Mavic Pro: GPS(lon, lat, sats), lon beyond 90
  const FlightTrack t = Read(
      "1\n00:00:01,000 --> 00:00:02,000\nHOME(149.0251,-20.2532) 2017.08.05 14:11:51\nGPS(149.0251,-20.2533,16) "
      "BAROMETER:1.9\nISO:100 Shutter:60 EV: Fnum:2.2\n\n"
      "2\n00:00:02,000 --> 00:00:03,000\nHOME(149.0251,-20.2532) 2017.08.05 14:11:52\nGPS(149.0252,-20.2534,15) "
      "BAROMETER:2.5\nISO:100 Shutter:60 EV: Fnum:2.2\n");
  ASSERT_EQ(t.fixes.size(), 2u);
  EXPECT_DOUBLE_EQ(t.fixes[1].lat_deg, -20.2534);
  EXPECT_DOUBLE_EQ(t.fixes[1].lon_deg, 149.0252);
  EXPECT_DOUBLE_EQ(t.fixes[1].alt_m, 2.5);
  EXPECT_EQ(t.fixes[1].alt_ref, AltitudeReference::kTakeoff);
  EXPECT_EQ(t.fixes[0].satellites, 16);
  EXPECT_EQ(t.fixes[0].t_ns, 1000000000);
  EXPECT_TRUE(HasNote(t, "(lon, lat): a first value beyond +-90"));
  EXPECT_TRUE(HasNote(t, "home point: lat -20.2532, lon 149.0251"));
}

TEST(DjiSrt, LatLonOrderByMagnitude) {
  const FlightTrack t = Read("1\n00:00:00,000 --> 00:00:01,000\nGPS(36.6146,-120.1120,0.0M) BAROMETER:0.3M\n");
  ASSERT_EQ(t.fixes.size(), 1u);
  EXPECT_DOUBLE_EQ(t.fixes[0].lat_deg, 36.6146);
  EXPECT_DOUBLE_EQ(t.fixes[0].lon_deg, -120.112);
  EXPECT_DOUBLE_EQ(t.fixes[0].alt_m, 0.3);
  EXPECT_TRUE(HasNote(t, "(lat, lon): a second value beyond +-90"));
}

TEST(DjiSrt, AmbiguousOrderDialectDefaults) {
  // DJI GO 4 style GPS(x, y, n): (lon, lat); Matrice style GPS(x, y, altM): (lat, lon).
  const FlightTrack go = Read(
      "1\n00:00:00,000 --> 00:00:01,000\nF/5.6, SS 400, ISO 100, EV 0, GPS (-58.851745, -34.237922, 15), "
      "HOME (-58.847509, -34.232707, -57.98m), D 698.70m, H 85.80m, H.S 2.88m/s, V.S 0.00m/s, "
      "F.PRY (2.7\xC2\xB0, -7.0\xC2\xB0, 110.1\xC2\xB0), G.PRY (-24.4\xC2\xB0, 0.0\xC2\xB0, 110.4\xC2\xB0)\n");
  ASSERT_EQ(go.fixes.size(), 1u);
  EXPECT_DOUBLE_EQ(go.fixes[0].lat_deg, -34.237922);
  EXPECT_DOUBLE_EQ(go.fixes[0].lon_deg, -58.851745);
  EXPECT_DOUBLE_EQ(go.fixes[0].alt_m, 85.8);
  EXPECT_DOUBLE_EQ(go.fixes[0].ground_speed_m_s, 2.88);
  EXPECT_EQ(go.fixes[0].satellites, 15);
  EXPECT_TRUE(HasNote(go, "dialect default for GPS(x, y, n)"));
  // F.PRY (pitch 2.7, roll -7.0, yaw 110.1) -> quaternion; check by recovering yaw.
  ASSERT_EQ(go.attitude.size(), 1u);
  const AttitudeSample& a = go.attitude[0];
  const double yaw = std::atan2(2 * (a.qw * a.qz + a.qx * a.qy), 1 - 2 * (a.qy * a.qy + a.qz * a.qz)) * 180 / M_PI;
  const double pitch = std::asin(2 * (a.qw * a.qy - a.qz * a.qx)) * 180 / M_PI;
  const double roll = std::atan2(2 * (a.qw * a.qx + a.qy * a.qz), 1 - 2 * (a.qx * a.qx + a.qy * a.qy)) * 180 / M_PI;
  EXPECT_NEAR(yaw, 110.1, 1e-9);
  EXPECT_NEAR(pitch, 2.7, 1e-9);
  EXPECT_NEAR(roll, -7.0, 1e-9);

  const FlightTrack m300 =
      Read("1\n00:00:00,000 --> 00:00:01,000\n2022.06.21 16:06:17\nGPS(36.6146,-6.1120,0.0M) BAROMETER:0.3M\n");
  EXPECT_DOUBLE_EQ(m300.fixes[0].lat_deg, 36.6146);
  EXPECT_DOUBLE_EQ(m300.fixes[0].lon_deg, -6.112);
  EXPECT_TRUE(HasNote(m300, "dialect default for GPS(x, y, altM)"));
}

TEST(DjiSrt, OrderFromTaggedRecordsInSameFile) {
  const FlightTrack t = Read(
      "1\n00:15:04,904 --> 00:15:05,905\nF/5.6, GPS (-59.409424, -34.650200, 16), H 17.39m\n\n"
      "2\n00:15:09,942 --> 00:15:10,009\n[latitude : -34.651180] [longtitude : -59.409483] [altitude: 120.060997]\n");
  ASSERT_EQ(t.fixes.size(), 2u);
  EXPECT_DOUBLE_EQ(t.fixes[0].lat_deg, -34.6502);
  EXPECT_DOUBLE_EQ(t.fixes[0].lon_deg, -59.409424);
  EXPECT_EQ(t.fixes[0].alt_ref, AltitudeReference::kTakeoff);
  EXPECT_EQ(t.fixes[1].alt_ref, AltitudeReference::kAmsl);
  EXPECT_TRUE(HasNote(t, "nearer to the file's [latitude]/[longitude] records"));
}

TEST(DjiSrt, InconsistentOrder) {
  ExpectError(
      "1\n00:00:00,000 --> 00:00:01,000\nGPS(149.0,-20.0,16)\n\n2\n00:00:01,000 --> "
      "00:00:02,000\nGPS(-20.0,149.0,16)\n",
      7, 1, "order is inconsistent");
}

TEST(DjiSrt, DateTimesWithoutTimecodes) {  // Mavic 2 style
  const FlightTrack t = Read(
      "1\n2017.08.05 14:11:51,393,525,393,525\n[latitude : -20.2533] [longtitude : 149.0251] [iso : 100]\n\n"
      "2\n2017.08.05 14:11:52,393,525\n[latitude : -20.2534] [longtitude : 149.0252] [iso : 100]\n");
  ASSERT_EQ(t.fixes.size(), 2u);
  EXPECT_EQ(t.fixes[0].t_ns, 0);
  EXPECT_EQ(t.fixes[1].t_ns, 1000000000);
  EXPECT_TRUE(std::isnan(t.fixes[0].alt_m));
  EXPECT_TRUE(HasNote(t, "minus the first record's"));
}

TEST(DjiSrt, NotAvailableFixesCounted) {
  const FlightTrack t = Read(
      "1\n00:00:01,000 --> 00:00:02,000\nGPS(N/A,N/A,3) BAROMETER:0.0\n\n2\n00:00:02,000 --> "
      "00:00:03,000\nGPS(-1.2218,42.4668,11) BAROMETER:0.5\n");
  ASSERT_EQ(t.fixes.size(), 1u);
  EXPECT_TRUE(HasNote(t, "1 subtitles without a GPS fix"));
}

TEST(DjiSrt, EmptyFile) { ExpectError("", 1, -1, "empty file"); }
TEST(DjiSrt, OnlyIndex) { ExpectError("1\n", 1, -1, "none of the 1 subtitles has a GPS position"); }
TEST(DjiSrt, TruncatedLastRecord) {
  ExpectError("1\n00:00:01,000 --> 00:00:02,000\nGPS(149.0,-20.0,16)\n\n2\n00:00:02,000 --> 00:00:03,000\n", 5, -1,
              "subtitle 2 has no GPS position");
}
TEST(DjiSrt, UnterminatedBracket) {
  ExpectError("1\n00:00:00,000 --> 00:00:00,040\n[iso : 100] [latitude : -34.86995] [lo", 3, 36, "unterminated '['");
}
TEST(DjiSrt, LatitudeWithoutLongitude) {
  ExpectError("1\n00:00:00,000 --> 00:00:00,040\n[latitude : -34.86995]\n", 1, -1, "latitude but no longitude");
}
TEST(DjiSrt, BadNumber) {
  ExpectError("1\n00:00:00,000 --> 00:00:00,040\n[latitude : -34.8x] [longitude : 1.0]\n", 3, 13,
              "latitude: not a number");
}
TEST(DjiSrt, BadTimecode) {
  ExpectError("1\n00:00:0O,000 --> 00:00:01,000\nGPS(149.0,-20.0,16)\n", 2, 1, "malformed subtitle timecode");
}
TEST(DjiSrt, NotSrt) { ExpectError("hello world\n", 1, 1, "not a DJI SRT file"); }
TEST(DjiSrt, PositionOutOfRange) {
  ExpectError("1\n00:00:00,000 --> 00:00:00,040\n[latitude : 95.0] [longitude : 1.0]\n", 3, 13,
              "position out of range");
}

// ---- Real samples (DJI_SRT_Parser test files) ----

std::filesystem::path SampleDir() { return testing::DataRoot() / "dji_srt" / "samples"; }

TEST(DjiSrtSamples, Nominal) {
  if (!std::filesystem::is_directory(SampleDir())) GTEST_SKIP() << "no " << SampleDir() << " (set ROADSURVEY_DATA)";
  struct Expect {
    const char* file;
    size_t fixes;
    double lat, lon, alt;
    AltitudeReference ref;
    int64_t last_t_ns;
  };
  // Counts, first positions (the file's own text) and last subtitle start times, read off the files with grep.
  const Expect kExpect[] = {
      {"MAVIC3.srt", 12318, 3.41531, -3.37440, 0.401, AltitudeReference::kAmsl, 246340000000},
      {"air2s.srt", 17, 41.424724, 2.234156, 117.0, AltitudeReference::kAmsl, 533000000},
      {"matrice_300.srt", 381, 36.6146, -6.1120, 0.3, AltitudeReference::kTakeoff, 380000000000},
      {"mavic_air2.srt", 25, 41.420684, 2.162162, 27.3, AltitudeReference::kAmsl, 400000000},
      {"m2zoom.SRT", 7113, 31.452012, 74.398751, 213.983002, AltitudeReference::kAmsl, 118651000000},
      {"mavic_2_style.SRT", 468, -20.2533, 149.0251, kNaN, AltitudeReference::kUnknown, 468000000000},
      {"mavic_2pro_new.SRT", 8952, -35.080155, -60.286702, kNaN, AltitudeReference::kUnknown, 369840000000},
      {"mavic_mini.SRT", 117, 48.0771, -121.7458, 200.70, AltitudeReference::kTakeoff, 116000000000},
      {"mavic_pro.SRT", 468, -20.2533, 149.0251, 1.9, AltitudeReference::kTakeoff, 468000000000},
      {"mavic_pro_buggy.SRT", 530, 42.4668, -1.2218, 0.0, AltitudeReference::kTakeoff, 546000000000},
      {"old_format.SRT", 468, -20.2533, 149.0251, 1.9, AltitudeReference::kTakeoff, 468000000000},
      {"p4_rtk.SRT", 55, -34.237922, -58.851745, 85.80, AltitudeReference::kTakeoff, 54000000000},
      {"p4p_sample.SRT", 5, 47.4692, 8.2090, 45.60, AltitudeReference::kTakeoff, 4000000000},
      {"mix_p4rtk_mavic2pro.srt", 12, -34.650200, -59.409424, 17.39, AltitudeReference::kTakeoff, 910242000000},
  };
  for (const Expect& e : kExpect) {
    SCOPED_TRACE(e.file);
    const FlightTrack t = ReadDjiSrt(SampleDir() / e.file);
    ASSERT_EQ(t.fixes.size(), e.fixes);
    EXPECT_NEAR(t.fixes[0].lat_deg, e.lat, 1e-12);
    EXPECT_NEAR(t.fixes[0].lon_deg, e.lon, 1e-12);
    if (std::isnan(e.alt))
      EXPECT_TRUE(std::isnan(t.fixes[0].alt_m));
    else
      EXPECT_NEAR(t.fixes[0].alt_m, e.alt, 1e-12);
    EXPECT_EQ(t.fixes[0].alt_ref, e.ref);
    EXPECT_EQ(t.fixes.back().t_ns, e.last_t_ns);
  }
  // The buggy Mavic Pro file has 16 GPS(N/A,...) records: dropped and counted.
  EXPECT_TRUE(HasNote(ReadDjiSrt(SampleDir() / "mavic_pro_buggy.SRT"), "16 subtitles without a GPS fix"));
  EXPECT_EQ(ReadDjiSrt(SampleDir() / "p4_rtk.SRT").attitude.size(), 55u);
}

TEST(DjiSrtSamples, BrokenFilesGiveLocatedErrors) {
  if (!std::filesystem::is_directory(SampleDir())) GTEST_SKIP() << "no " << SampleDir() << " (set ROADSURVEY_DATA)";
  struct Expect {
    const char* file;
    int64_t line, column;
    const char* what;
  };
  const Expect kExpect[] = {
      {"broken_empty.SRT", 1, -1, "empty file"},
      {"broken_empty2.SRT", 1, -1, "none of the 1 subtitles"},
      {"broken_incomplete.SRT", 115, -1, "subtitle 20 has no GPS position"},
      {"broken_incomplete2.SRT", 17, 107, "unterminated '['"},
      {"mavic_air.SRT", 1, -1, "none of the 2 subtitles has a GPS position"},  // exposure-only firmware
  };
  for (const Expect& e : kExpect) {
    SCOPED_TRACE(e.file);
    try {
      ReadDjiSrt(SampleDir() / e.file);
      ADD_FAILURE() << "no error";
    } catch (const InputError& err) {
      EXPECT_EQ(err.where().line, e.line) << err.what();
      EXPECT_EQ(err.where().column, e.column) << err.what();
      EXPECT_NE(err.message().find(e.what), std::string::npos) << err.what();
    }
  }
}

TEST(DjiSrtSamples, TruncatedAndBitFlippedCopies) {
  if (!std::filesystem::is_directory(SampleDir())) GTEST_SKIP() << "no " << SampleDir() << " (set ROADSURVEY_DATA)";
  int total = 0, errors = 0;
  for (const auto& entry : std::filesystem::directory_iterator(SampleDir())) {
    const std::string ext = entry.path().extension().string();
    if (ext != ".srt" && ext != ".SRT") continue;
    const std::string text = testing::Slurp(entry.path(), 32 << 10);  // the head is enough, keeps the test fast
    const auto st = testing::Mutate(
        text, [&](std::istream& in) { return ReadDjiSrt(in, "m.srt"); }, 20, 60, 1234);
    total += st.parsed + st.input_errors;
    errors += st.input_errors;
    EXPECT_EQ(st.input_errors_with_line, st.input_errors) << entry.path() << ": every SRT error names a line";
  }
  EXPECT_GT(total, 1000);
  EXPECT_GT(errors, 0);
}

}  // namespace
}  // namespace rs
