#include "formats/flight_log/flight_csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "formats/flight_log/sample_mutation.h"
#include "formats/input_error.h"

namespace rs {
namespace {

FlightTrack Read(const std::string& text) {
  std::istringstream in(text);
  return ReadFlightCsv(in, "f.csv");
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

TEST(FlightCsv, Nominal) {  // ISO-8601 times, generic names
  const FlightTrack t = Read(
      "timestamp,latitude,longitude,altitude,speed(km/h),sats,battery\n"
      "2015-12-11T15:43:13.5+01:00,46.5,14.25,300.5,36,12,90\n"
      "2015-12-11T14:43:14Z,46.6,14.35,301.5,18,11,89\n");
  EXPECT_EQ(t.format, "csv");
  EXPECT_EQ(t.time_base, TimeBase::kUtc);
  ASSERT_EQ(t.fixes.size(), 2u);
  EXPECT_EQ(t.fixes[0].t_ns, 1449844993500000000LL);
  EXPECT_EQ(t.fixes[1].t_ns, 1449844994000000000LL);
  EXPECT_DOUBLE_EQ(t.fixes[0].lat_deg, 46.5);
  EXPECT_DOUBLE_EQ(t.fixes[0].lon_deg, 14.25);
  EXPECT_DOUBLE_EQ(t.fixes[0].alt_m, 300.5);
  EXPECT_EQ(t.fixes[0].alt_ref, AltitudeReference::kUnknown);
  EXPECT_NEAR(t.fixes[0].ground_speed_m_s, 10.0, 1e-12);
  EXPECT_EQ(t.fixes[1].satellites, 11);
  EXPECT_TRUE(HasNote(t, "columns not used: battery"));
  EXPECT_TRUE(HasNote(t, "altitude from column 'altitude' (unknown)"));
}

TEST(FlightCsv, EpochSecondsAndMillisecondsByMagnitude) {
  const FlightTrack s = Read("time,lat,lng,alt_msl\n1449844993.25,1,2,3\n");
  EXPECT_EQ(s.fixes[0].t_ns, 1449844993250000000LL);
  EXPECT_EQ(s.fixes[0].alt_ref, AltitudeReference::kAmsl);
  const FlightTrack ms = Read("timestamp;lat;lon\n1449844993250;1;2\n");  // semicolons too
  EXPECT_EQ(ms.fixes[0].t_ns, 1449844993250000000LL);
}

TEST(FlightCsv, RelativeTimeIsBoot) {
  const FlightTrack t = Read("time(s),lat,lon,height_above_takeoff(m)\n0.5,1,2,10\n1.5,1.1,2.1,11\n");
  EXPECT_EQ(t.time_base, TimeBase::kBoot);
  EXPECT_EQ(t.fixes[1].t_ns, 1500000000);
  EXPECT_EQ(t.fixes[1].alt_ref, AltitudeReference::kTakeoff);
}

TEST(FlightCsv, NoTimeColumnSaysSo) {
  const FlightTrack t = Read("lat,lon\n1,2\n3,4\n");
  EXPECT_EQ(t.time_base, TimeBase::kBoot);
  EXPECT_EQ(t.fixes[1].t_ns, 1);
  EXPECT_TRUE(HasNote(t, "the track has NO time"));
}

// An AirData export: 1 s datetime(utc), 100 ms time(millisecond), feet and mph, photo flag.
TEST(FlightCsv, AirData) {
  std::string csv =
      "time(millisecond),datetime(utc),latitude,longitude,height_above_takeoff(feet),height_above_ground_at_drone_"
      "location(feet),"
      "ground_elevation_at_drone_location(feet),altitude_above_seaLevel(feet),height_sonar(feet),speed(mph),distance("
      "feet),"
      "mileage(feet),satellites,gpslevel,voltage(v),max_altitude(feet),max_ascent(feet),max_speed(mph),max_distance("
      "feet),"
      " xSpeed(mph), ySpeed(mph), zSpeed(mph), compass_heading(degrees), pitch(degrees), "
      "roll(degrees),isPhoto,isVideo\n";
  // True UTC of time 0 is 2019-05-03T14:22:10.750Z: rows at 0..2000 ms every 100 ms.
  const int64_t utc0_ns = 1556893330750000000LL;
  for (int i = 0; i <= 20; ++i) {
    const int64_t t_ms = 100 * i;
    const int64_t utc_s = (utc0_ns + t_ms * 1000000) / 1000000000;  // truncated to the second, as AirData writes
    const int64_t sod = utc_s % 86400;
    char dt[64];
    std::snprintf(dt, sizeof(dt), "2019-05-03 %02lld:%02lld:%02lld", static_cast<long long>(sod / 3600),
                  static_cast<long long>(sod / 60 % 60), static_cast<long long>(sod % 60));
    const bool photo = i >= 5 && i <= 7;
    csv += std::to_string(t_ms) + "," + dt + "," + (i == 0 ? "0.0,0.0" : "46.05" + std::to_string(i) + ",14.5") +
           ",32.8084,0,0,1000,0,22.3694,0,0,14,4,15.4,0,0,0,0,0,0,0,90,-5,2," + (photo ? "1" : "0") + ",0\n";
  }
  const FlightTrack t = Read(csv);
  EXPECT_EQ(t.format, "airdata-csv");
  EXPECT_EQ(t.time_base, TimeBase::kUtc);
  ASSERT_EQ(t.fixes.size(), 20u);  // the 0,0 row is dropped
  EXPECT_TRUE(HasNote(t, "1 rows without a position"));
  // Anchor: the true offset lies within one sample interval (100 ms) below.
  for (size_t k = 0; k < t.fixes.size(); ++k) {
    const int64_t truth = utc0_ns + static_cast<int64_t>(k + 1) * 100000000;
    EXPECT_LE(t.fixes[k].t_ns, truth);
    EXPECT_GT(t.fixes[k].t_ns, truth - 100000000);
  }
  EXPECT_EQ(t.fixes[1].t_ns - t.fixes[0].t_ns, 100000000);
  EXPECT_NEAR(t.fixes[0].alt_m, 304.8, 1e-9);  // altitude_above_seaLevel preferred over take-off height
  EXPECT_EQ(t.fixes[0].alt_ref, AltitudeReference::kAmsl);
  EXPECT_NEAR(t.fixes[0].ground_speed_m_s, 10.0, 1e-4);  // 22.3694 mph
  EXPECT_EQ(t.fixes[0].satellites, 14);
  ASSERT_EQ(t.attitude.size(), 21u);
  ASSERT_EQ(t.camera_events.size(), 1u);  // one rising edge of isPhoto
  EXPECT_EQ(t.camera_events[0].t_ns, t.fixes[4].t_ns);
  EXPECT_TRUE(HasNote(t, "altitude from column 'altitude_above_seaLevel(feet)' (amsl, feet converted to metres)"));
  EXPECT_TRUE(HasNote(t, "anchored to 'time(millisecond)'"));
}

TEST(FlightCsv, NoLatitudeColumn) { ExpectError("time,x,lon\n1,2,3\n", 1, -1, "header has no latitude column"); }
TEST(FlightCsv, EmptyFile) { ExpectError("\n# comment\n", 1, -1, "empty file"); }
TEST(FlightCsv, WrongFieldCount) { ExpectError("lat,lon,alt\n1,2,3\n1,2\n", 3, -1, "expected 3 fields"); }
TEST(FlightCsv, BadNumber) { ExpectError("lat,lon\n1,2\n1,x2\n", 3, 3, "column 'lon': not a number"); }
TEST(FlightCsv, LatitudeOutOfRange) { ExpectError("lat,lon\n100,2\n", 2, 1, "outside [-90, 90]"); }
TEST(FlightCsv, BadIsoTime) {
  ExpectError("datetime,lat,lon\n2019-05-03T14:22:11Z,1,2\n2019-05-33T14:22:11Z,1,2\n", 3, 1, "not an ISO-8601");
}
TEST(FlightCsv, EpochOfUnknownUnit) { ExpectError("timestamp,lat,lon\n12345,1,2\n", 2, 1, "not an epoch time"); }
TEST(FlightCsv, UnknownUnit) {
  ExpectError("lat,lon,altitude(furlongs)\n1,2,3\n", 1, 9, "unknown length unit 'furlongs'");
}
TEST(FlightCsv, HalfPosition) { ExpectError("lat,lon\n1,\n", 2, 3, "both set or both empty"); }
TEST(FlightCsv, NoPositions) { ExpectError("lat,lon\n,\n", 1, -1, "no row has a position"); }

TEST(FlightCsv, TruncatedAndBitFlippedCopies) {
  std::string csv =
      "time(millisecond),datetime(utc),latitude,longitude,altitude_above_seaLevel(feet),speed(mph),isPhoto\n";
  for (int i = 0; i < 200; ++i)
    csv += std::to_string(i * 100) + ",2019-05-03 14:22:" + std::to_string(10 + i / 10) + "," +
           std::to_string(46 + i * 1e-5) + ",14.5,1000,20," + (i % 30 == 0 ? "1" : "0") + "\n";
  const auto st = testing::Mutate(
      csv, [](std::istream& in) { return ReadFlightCsv(in, "m.csv"); }, 30, 300, 7);
  EXPECT_GT(st.input_errors, 10);
  EXPECT_EQ(st.input_errors_with_line, st.input_errors);
}

}  // namespace
}  // namespace rs
