#include "formats/flight_log/gpx.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <sstream>

#include "formats/flight_log/sample_mutation.h"
#include "formats/input_error.h"

namespace rs {
namespace {

FlightTrack Read(const std::string& text) {
  std::istringstream in(text);
  return ReadGpx(in, "t.gpx");
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

constexpr const char* kHead =
    "<?xml version=\"1.0\"?>\n<gpx version=\"1.1\" creator=\"t\" xmlns=\"http://www.topografix.com/GPX/1/1\">\n";

TEST(Gpx, Nominal) {
  const FlightTrack t = Read(
      std::string(kHead) +
      "<trk><trkseg>\n"
      "<trkpt lat=\"57.011456\" "
      "lon=\"9.992872\"><ele>23.5536</ele><time>2015-12-11T15:43:13.000+01:00</time><sat>9</sat><fix>3d</fix></trkpt>\n"
      "<trkpt lat=\"57.01147\" lon=\"9.992874\"><ele>23.551199</ele><time>2015-12-11T14:43:13.994Z</time></trkpt>\n"
      "</trkseg><trkseg><trkpt lat=\"-1e-3\" lon=\"-179.5\"><time>2015-12-11T14:43:15Z</time></trkpt></trkseg></trk>\n"
      "<wpt lat=\"1\" lon=\"2\"/>\n</gpx>\n");
  EXPECT_EQ(t.format, "gpx");
  EXPECT_EQ(t.time_base, TimeBase::kUtc);
  ASSERT_EQ(t.fixes.size(), 3u);
  EXPECT_EQ(t.fixes[0].t_ns, 1449844993000000000LL);
  EXPECT_EQ(t.fixes[1].t_ns, 1449844993994000000LL);
  EXPECT_DOUBLE_EQ(t.fixes[0].lat_deg, 57.011456);
  EXPECT_DOUBLE_EQ(t.fixes[0].lon_deg, 9.992872);
  EXPECT_DOUBLE_EQ(t.fixes[0].alt_m, 23.5536);
  EXPECT_EQ(t.fixes[0].alt_ref, AltitudeReference::kAmsl);
  EXPECT_EQ(t.fixes[0].satellites, 9);
  EXPECT_EQ(t.fixes[0].fix_type, 3);
  EXPECT_DOUBLE_EQ(t.fixes[2].lat_deg, -0.001);
  EXPECT_TRUE(std::isnan(t.fixes[2].alt_m));
  EXPECT_EQ(t.fixes[2].alt_ref, AltitudeReference::kUnknown);
  EXPECT_TRUE(HasNote(t, "1 <wpt> ignored"));
  EXPECT_TRUE(HasNote(t, "mean sea level"));
}

TEST(Gpx, NoTimeKeepsPointsAndSaysSo) {
  const FlightTrack t =
      Read(std::string(kHead) +
           "<rte><rtept lat=\"1\" lon=\"2\"/><rtept lat=\"3\" lon=\"4\"/><rtept lat=\"5\" lon=\"6\"/></rte></gpx>");
  EXPECT_EQ(t.time_base, TimeBase::kBoot);
  ASSERT_EQ(t.fixes.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(t.fixes[i].t_ns, i);
    EXPECT_DOUBLE_EQ(t.fixes[i].lat_deg, 1 + 2 * i);
  }
  EXPECT_TRUE(HasNote(t, "the track has NO time"));
}

TEST(Gpx, UntimedPointsAmongTimedAreDroppedAndCounted) {
  const FlightTrack t = Read(std::string(kHead) +
                             "<trk><trkseg><trkpt lat=\"1\" lon=\"2\"><time>2013-05-18T08:23:04Z</time></trkpt>"
                             "<trkpt lat=\"3\" lon=\"4\"/></trkseg></trk></gpx>");
  ASSERT_EQ(t.fixes.size(), 1u);
  EXPECT_EQ(t.fixes[0].t_ns, 1368865384000000000LL);
  EXPECT_TRUE(HasNote(t, "1 points without <time> dropped"));
}

TEST(Gpx, Gpx10SpeedAndNoZone) {
  const FlightTrack t = Read(
      "<gpx version=\"1.0\" xmlns=\"http://www.topografix.com/GPX/1/0\"><trk><trkseg>"
      "<trkpt lat=\"10.1\" "
      "lon=\"-20.2\"><time>2013-01-01T12:00:04</time><speed>3.5</speed></trkpt></trkseg></trk></gpx>");
  ASSERT_EQ(t.fixes.size(), 1u);
  EXPECT_DOUBLE_EQ(t.fixes[0].ground_speed_m_s, 3.5);
  EXPECT_TRUE(HasNote(t, "without a zone, taken as UTC"));
}

TEST(Gpx, MalformedXmlHasLineAndColumn) {
  ExpectError(std::string(kHead) + "<trk><trkseg>\n  <trkpt lat=\"1\" lon=\"2\"></trkseg>\n", 4, 28, "malformed XML");
}
TEST(Gpx, NotGpx) { ExpectError("<kml><Document/></kml>", 1, 1, "root element is <kml>"); }
TEST(Gpx, NoPoints) {
  ExpectError(std::string(kHead) + "<trk><trkseg/></trk></gpx>", 2, 1, "no track, route or waypoint points");
}
TEST(Gpx, MissingLon) { ExpectError(std::string(kHead) + "<wpt lat=\"1\"/></gpx>", 3, 1, "lacks the lon attribute"); }
TEST(Gpx, BadLat) {
  ExpectError(std::string(kHead) + "<wpt lat=\"1,5\" lon=\"2\"/></gpx>", 3, 1, "lat=\"1,5\" is not a number");
}
TEST(Gpx, LatOutOfRange) {
  ExpectError(std::string(kHead) + "<wpt lat=\"91\" lon=\"2\"/></gpx>", 3, 1, "outside [-90, 90]");
}
TEST(Gpx, BadTime) {
  ExpectError(std::string(kHead) + "<wpt lat=\"1\" lon=\"2\">\n <time>yesterday</time></wpt></gpx>", 4, 2,
              "not an ISO-8601");
}
TEST(Gpx, BadEle) {
  ExpectError(std::string(kHead) + "<wpt lat=\"1\" lon=\"2\"><ele>high</ele></wpt></gpx>", 3, 22, "<ele>");
}

// ---- Real samples (gpxpy test files) ----

std::filesystem::path SampleDir() { return testing::DataRoot() / "gpx_tracks" / "test_files"; }

TEST(GpxSamples, EveryFileParsesOrIsRejectedWithAReason) {
  if (!std::filesystem::is_directory(SampleDir())) GTEST_SKIP() << "no " << SampleDir() << " (set ROADSURVEY_DATA)";
  // Files without any point are rejected; all others parse.
  const std::set<std::string> kRejected = {"custom_schema_locations.gpx", "default_schema_locations.gpx",
                                           "unicode2.gpx"};
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(SampleDir())) {
    if (entry.path().extension() != ".gpx") continue;
    ++n;
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    try {
      const FlightTrack t = ReadGpx(entry.path());
      EXPECT_FALSE(kRejected.count(name));
      EXPECT_FALSE(t.fixes.empty());
    } catch (const InputError& e) {
      EXPECT_TRUE(kRejected.count(name)) << e.what();
      EXPECT_NE(e.message().find("no track, route or waypoint points"), std::string::npos);
      EXPECT_GE(e.where().line, 1);
    }
  }
  EXPECT_EQ(n, 28);
}

TEST(GpxSamples, Nominal) {
  if (!std::filesystem::is_directory(SampleDir())) GTEST_SKIP() << "no " << SampleDir() << " (set ROADSURVEY_DATA)";
  const FlightTrack less = ReadGpx(SampleDir() / "track-with-less-sec-time.gpx");
  ASSERT_EQ(less.fixes.size(), 2u);
  EXPECT_EQ(less.fixes[1].t_ns, 1449844993994000000LL);  // 2015-12-11T15:43:13.994+01:00
  EXPECT_DOUBLE_EQ(less.fixes[1].lat_deg, 57.01147);
  EXPECT_DOUBLE_EQ(less.fixes[1].alt_m, 23.551199);
  // All Mojstrovka times are the 1901-12-13 sentinel: kept as an untimed track.
  const FlightTrack moj = ReadGpx(SampleDir() / "Mojstrovka.gpx");
  EXPECT_EQ(moj.time_base, TimeBase::kBoot);
  EXPECT_EQ(moj.fixes.size(), 184u);
  EXPECT_TRUE(HasNote(moj, "184 <time> values before 1980"));
  const FlightTrack route = ReadGpx(SampleDir() / "route.gpx");
  EXPECT_EQ(route.fixes.size(), 55u);
  EXPECT_EQ(route.time_base, TimeBase::kBoot);
  const FlightTrack cerk = ReadGpx(SampleDir() / "cerknicko-jezero.gpx");
  EXPECT_EQ(cerk.fixes.size(), 296u);
  EXPECT_EQ(cerk.fixes[0].t_ns, 1281018239000000000LL);
  const FlightTrack bom = ReadGpx(SampleDir() / "unicode_with_bom.gpx");
  EXPECT_EQ(bom.fixes.size(), 1u);
}

TEST(GpxSamples, TruncatedAndBitFlippedCopies) {
  if (!std::filesystem::is_directory(SampleDir())) GTEST_SKIP() << "no " << SampleDir() << " (set ROADSURVEY_DATA)";
  int errors = 0, errors_with_line = 0;
  for (const auto& entry : std::filesystem::directory_iterator(SampleDir())) {
    if (entry.path().extension() != ".gpx") continue;
    const std::string text = testing::Slurp(entry.path(), 32 << 10);
    const auto st = testing::Mutate(
        text, [&](std::istream& in) { return ReadGpx(in, "m.gpx"); }, 10, 30, 99);
    errors += st.input_errors;
    errors_with_line += st.input_errors_with_line;
  }
  EXPECT_GT(errors, 100);
  EXPECT_EQ(errors_with_line, errors);  // every GPX error is located
}

}  // namespace
}  // namespace rs
