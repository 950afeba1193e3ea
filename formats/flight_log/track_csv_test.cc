#include "formats/flight_log/track_csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "formats/input_error.h"

namespace rs {
namespace {

constexpr const char* kHeader =
    "t_ns,type,lat_deg,lon_deg,alt_m,alt_ref,fix_type,satellites,h_acc_m,v_acc_m,qw,qx,qy,qz,sequence\n";

FlightTrack Read(const std::string& text) {
  std::istringstream in(text);
  return ReadTrackCsv(in, "t.csv");
}

// Expects an InputError at `line` (and `column` when >= 0) whose message contains `what`.
void ExpectError(const std::string& text, int64_t line, int64_t column, const std::string& what) {
  try {
    Read(text);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "t.csv");
    EXPECT_EQ(e.where().line, line) << e.what();
    if (column >= 0) {
      EXPECT_EQ(e.where().column, column) << e.what();
    }
    EXPECT_NE(e.message().find(what), std::string::npos) << e.what();
  }
}

FlightTrack SampleTrack() {
  FlightTrack t;
  t.time_base = TimeBase::kUtc;
  t.notes = {"simulated flight, seed 7", "second note"};
  for (int i = 0; i < 50; ++i) {
    GnssFix f;
    f.t_ns = 1700000000000000000LL + i * 200000000LL;
    f.lat_deg = 46.0512345678901 + i * 1.234567e-6;
    f.lon_deg = 14.5054321098765 - i * 7.654321e-7;
    f.alt_m = 312.25 + 0.1 * i;
    f.alt_ref = (i % 2) ? AltitudeReference::kAmsl : AltitudeReference::kEllipsoid;
    f.fix_type = i % 7;
    f.satellites = i % 3 == 0 ? -1 : 10 + i % 5;
    f.h_acc_m = i % 4 == 0 ? kNaN : 0.01 * i + 0.3;
    f.v_acc_m = 0.1 / 3;
    f.ground_speed_m_s = i % 5 == 0 ? kNaN : 4.2 + i / 7.0;
    t.fixes.push_back(f);
    AttitudeSample a;
    a.t_ns = f.t_ns + 50000000;
    const double half = 0.01 * i;
    a.qw = std::cos(half);
    a.qz = std::sin(half) * 0.6;
    a.qx = std::sin(half) * 0.8;
    t.attitude.push_back(a);
    if (i % 10 == 0) {
      CameraEvent c;
      c.t_ns = f.t_ns;  // tie with the fix on purpose
      c.sequence = i / 10;
      if (i != 20) {
        c.lat_deg = f.lat_deg, c.lon_deg = f.lon_deg, c.alt_m = 7.5 + i, c.alt_ref = AltitudeReference::kTakeoff;
      }
      t.camera_events.push_back(c);
    }
  }
  return t;
}

// NaN-aware bitwise equality of doubles.
bool Same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

TEST(TrackCsv, Nominal) {
  const FlightTrack t = Read(std::string("# roadsurvey flight track v1, time_base=boot\n") + kHeader +
                             "1000,gnss,46.5,14.25,300.5,amsl,3,12,0.8,1.5,,,,,\n"
                             "\n"
                             "# a comment\n"
                             "1500,attitude,,,,,,,,,1,0,0,0,\n"
                             "2000,camera,46.5,14.25,,,,,,,,,,,4\n"
                             "3000,gnss,-33.9,151.2,,,,,,,,,,,\r\n");
  EXPECT_EQ(t.time_base, TimeBase::kBoot);
  EXPECT_EQ(t.format, "roadsurvey-csv");
  ASSERT_EQ(t.fixes.size(), 2u);
  EXPECT_EQ(t.fixes[0].t_ns, 1000);
  EXPECT_EQ(t.fixes[0].lat_deg, 46.5);
  EXPECT_EQ(t.fixes[0].lon_deg, 14.25);
  EXPECT_EQ(t.fixes[0].alt_m, 300.5);
  EXPECT_EQ(t.fixes[0].alt_ref, AltitudeReference::kAmsl);
  EXPECT_EQ(t.fixes[0].fix_type, 3);
  EXPECT_EQ(t.fixes[0].satellites, 12);
  EXPECT_EQ(t.fixes[0].h_acc_m, 0.8);
  EXPECT_EQ(t.fixes[0].v_acc_m, 1.5);
  EXPECT_TRUE(std::isnan(t.fixes[1].alt_m));
  EXPECT_EQ(t.fixes[1].alt_ref, AltitudeReference::kUnknown);
  EXPECT_EQ(t.fixes[1].fix_type, -1);
  EXPECT_EQ(t.fixes[1].satellites, -1);
  ASSERT_EQ(t.attitude.size(), 1u);
  EXPECT_EQ(t.attitude[0].qw, 1.0);
  ASSERT_EQ(t.camera_events.size(), 1u);
  EXPECT_EQ(t.camera_events[0].sequence, 4);
  EXPECT_TRUE(std::isnan(t.camera_events[0].alt_m));
  EXPECT_TRUE(t.notes.empty());
}

TEST(TrackCsv, RoundTripIsBitExact) {
  const FlightTrack t = SampleTrack();
  std::stringstream ss;
  WriteTrackCsv(ss, t);
  const FlightTrack r = ReadTrackCsv(ss, "rt.csv");
  EXPECT_EQ(r.time_base, t.time_base);
  EXPECT_EQ(r.notes, t.notes);
  ASSERT_EQ(r.fixes.size(), t.fixes.size());
  for (size_t i = 0; i < t.fixes.size(); ++i) {
    const GnssFix &a = t.fixes[i], &b = r.fixes[i];
    EXPECT_EQ(a.t_ns, b.t_ns);
    EXPECT_EQ(a.lat_deg, b.lat_deg);
    EXPECT_EQ(a.lon_deg, b.lon_deg);
    EXPECT_EQ(a.alt_m, b.alt_m);
    EXPECT_EQ(a.alt_ref, b.alt_ref);
    EXPECT_EQ(a.fix_type, b.fix_type);
    EXPECT_EQ(a.satellites, b.satellites);
    EXPECT_TRUE(Same(a.h_acc_m, b.h_acc_m)) << i;
    EXPECT_TRUE(Same(a.v_acc_m, b.v_acc_m)) << i;
    EXPECT_TRUE(Same(a.ground_speed_m_s, b.ground_speed_m_s)) << i;
  }
  ASSERT_EQ(r.attitude.size(), t.attitude.size());
  for (size_t i = 0; i < t.attitude.size(); ++i) {
    EXPECT_EQ(r.attitude[i].t_ns, t.attitude[i].t_ns);
    EXPECT_EQ(r.attitude[i].qw, t.attitude[i].qw);
    EXPECT_EQ(r.attitude[i].qx, t.attitude[i].qx);
    EXPECT_EQ(r.attitude[i].qy, t.attitude[i].qy);
    EXPECT_EQ(r.attitude[i].qz, t.attitude[i].qz);
  }
  ASSERT_EQ(r.camera_events.size(), t.camera_events.size());
  for (size_t i = 0; i < t.camera_events.size(); ++i) {
    const CameraEvent &a = t.camera_events[i], &b = r.camera_events[i];
    EXPECT_EQ(a.t_ns, b.t_ns);
    EXPECT_EQ(a.sequence, b.sequence);
    EXPECT_TRUE(Same(a.lat_deg, b.lat_deg));
    EXPECT_TRUE(Same(a.lon_deg, b.lon_deg));
    EXPECT_TRUE(Same(a.alt_m, b.alt_m));
    EXPECT_EQ(a.alt_ref, b.alt_ref);
  }
  // Writing the read track again gives the same text (the format is canonical).
  std::stringstream again;
  WriteTrackCsv(again, r);
  EXPECT_EQ(again.str(), ss.str());
}

TEST(TrackCsv, WriterUsesDocumentedHeaderWithoutSpeed) {
  FlightTrack t;
  GnssFix f;
  f.t_ns = 5;
  f.lat_deg = 1, f.lon_deg = 2;
  t.fixes.push_back(f);
  std::stringstream ss;
  WriteTrackCsv(ss, t);
  EXPECT_EQ(ss.str(),
            std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "5,gnss,1,2,,unknown,,,,,,,,,\n");
}

TEST(TrackCsv, BadMagic) { ExpectError("t_ns,type\n", 1, 1, "not a roadsurvey track CSV"); }
TEST(TrackCsv, EmptyFile) { ExpectError("", 1, -1, "empty file"); }
TEST(TrackCsv, UnsupportedVersion) {
  ExpectError("# roadsurvey flight track v2, time_base=utc\n", 1, 1, "unsupported");
}
TEST(TrackCsv, BadTimeBase) { ExpectError("# roadsurvey flight track v1, time_base=gps\n", 1, 41, "utc or boot"); }
TEST(TrackCsv, MissingHeader) { ExpectError("# roadsurvey flight track v1, time_base=utc\n", 2, -1, "missing header"); }

TEST(TrackCsv, UnknownColumn) {
  ExpectError("# roadsurvey flight track v1, time_base=utc\nt_ns,type,lat_deg,speed\n", 2, 19,
              "unknown column 'speed'");
}

TEST(TrackCsv, MissingColumn) {
  ExpectError("# roadsurvey flight track v1, time_base=utc\nt_ns,type,lat_deg\n", 2, -1,
              "lacks required column 'lon_deg'");
}

TEST(TrackCsv, DuplicateColumn) {
  ExpectError("# roadsurvey flight track v1, time_base=utc\nt_ns,t_ns\n", 2, 6, "duplicate column");
}

TEST(TrackCsv, MissingRequiredField) {
  // lat_deg empty on a gnss row: column 8 is where the (empty) lat_deg field starts.
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,gnss,,14,,,,,,,,,,,\n", 3, 9,
              "lat_deg: required for gnss rows");
}

TEST(TrackCsv, FieldNotUsedByRowType) {
  ExpectError(
      std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,attitude,46,,,,,,,,1,0,0,0,\n", 3,
      13, "lat_deg: must be empty for attitude rows");
}

TEST(TrackCsv, WrongFieldCount) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,gnss,1,2\n", 3, -1,
              "expected 15 fields, got 4");
}

TEST(TrackCsv, BadNumber) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,gnss,46.0x,14,,,,,,,,,,,\n",
              3, 9, "not a number");
}

TEST(TrackCsv, LatitudeOutOfRange) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,gnss,96,14,,,,,,,,,,,\n", 3,
              9, "outside [-90, 90]");
}

TEST(TrackCsv, UnknownType) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,imu,,,,,,,,,,,,,\n", 3, 4,
              "not one of gnss");
}

TEST(TrackCsv, BadAltRef) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,gnss,1,2,3,msl,,,,,,,,,\n",
              3, 15, "'msl' is not one of");
}

TEST(TrackCsv, AltitudeWithoutReference) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,gnss,1,2,3,,,,,,,,,,\n", 3,
              15, "required when alt_m is set");
}

TEST(TrackCsv, NonUnitQuaternion) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "10,attitude,,,,,,,,,1,1,0,0,\n",
              3, -1, "quaternion norm");
}

TEST(TrackCsv, BadTime) {
  ExpectError(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader + "1.5e9,gnss,1,2,,,,,,,,,,,\n", 3,
              1, "t_ns: not an integer");
}

TEST(TrackCsv, OutOfOrderRowsAreSortedWithNote) {
  const FlightTrack t = Read(std::string("# roadsurvey flight track v1, time_base=utc\n") + kHeader +
                             "20,gnss,1,2,,,,,,,,,,,\n10,gnss,3,4,,,,,,,,,,,\n");
  ASSERT_EQ(t.fixes.size(), 2u);
  EXPECT_EQ(t.fixes[0].t_ns, 10);
  EXPECT_EQ(t.fixes[0].lat_deg, 3);
  ASSERT_EQ(t.notes.size(), 1u);
  EXPECT_NE(t.notes[0].find("1 fixes"), std::string::npos);
}

TEST(TrackCsv, MissingFile) { EXPECT_THROW(ReadTrackCsv(std::filesystem::path("/nonexistent/track.csv")), InputError); }

}  // namespace
}  // namespace rs
