#include "formats/flight_log/time_parse.h"

#include <gtest/gtest.h>

namespace rs::flightlog {
namespace {

// Truth values from Python's datetime (UTC epoch nanoseconds).
TEST(TimeParse, Nominal) {
  int64_t t = 0;
  bool zone = false;
  ASSERT_TRUE(ParseIso8601("1970-01-01T00:00:00Z", &t, &zone));
  EXPECT_EQ(t, 0);
  EXPECT_TRUE(zone);
  ASSERT_TRUE(ParseIso8601("2015-12-11T15:43:13.994+01:00", &t, &zone));
  EXPECT_EQ(t, 1449844993994000000LL);
  ASSERT_TRUE(ParseIso8601("2015-12-11T14:43:13.994Z", &t, &zone));
  EXPECT_EQ(t, 1449844993994000000LL);
  ASSERT_TRUE(ParseIso8601("2015-12-11T10:13:13.994-0430", &t, &zone));
  EXPECT_EQ(t, 1449844993994000000LL);
  ASSERT_TRUE(ParseIso8601("2000-02-29 23:59:59", &t, &zone));  // leap day, space separator, no zone
  EXPECT_EQ(t, 951868799000000000LL);
  EXPECT_FALSE(zone);
  ASSERT_TRUE(ParseIso8601("2011-09-26 13:17:59.293761040", &t, &zone));
  EXPECT_EQ(t, 1317043079293761040LL);
  ASSERT_TRUE(ParseIso8601("2013-05-18T08:23:04.12345678999Z", &t, &zone));  // >9 digits truncated
  EXPECT_EQ(t, 1368865384123456789LL);
}

TEST(TimeParse, Malformed) {
  int64_t t;
  bool zone;
  for (const char* s :
       {"", "2015-13-01T00:00:00Z", "2015-02-29T00:00:00Z", "2015-12-11T24:00:00Z", "2015-12-11T15:43:13.Z",
        "2015-12-11T15:43:13Zjunk", "2015-12-11", "15:43:13", "2015-12-11T15:43:13+25:00", "1e9"})
    EXPECT_FALSE(ParseIso8601(s, &t, &zone)) << s;
}

TEST(TimeParse, DjiDialects) {
  int64_t t = 0;
  size_t used = 0;
  ASSERT_TRUE(ParseDjiDateTime("2021-12-25 12:27:52.373", &used, &t));
  EXPECT_EQ(t, 1640435272373000000LL);
  EXPECT_EQ(used, 23u);
  ASSERT_TRUE(ParseDjiDateTime("2021-12-25 12:27:52,373,500 rest", &used, &t));
  EXPECT_EQ(t, 1640435272373500000LL);
  EXPECT_EQ(used, 27u);
  ASSERT_TRUE(ParseDjiDateTime("2017.8.5 14:11:51", &used, &t));
  EXPECT_EQ(t, 1501942311000000000LL);
  EXPECT_FALSE(ParseDjiDateTime("2017.08-05 14:11:51", &used, &t));  // mixed separators
  EXPECT_FALSE(ParseDjiDateTime("2017.08.05", &used, &t));
}

TEST(TimeParse, FormatRoundTrip) {
  EXPECT_EQ(FormatIsoNs(1317043079293761040LL), "2011-09-26T13:17:59.293761040");
  EXPECT_EQ(FormatIsoNs(0), "1970-01-01T00:00:00.000000000");
  EXPECT_EQ(FormatIsoNs(-1), "1969-12-31T23:59:59.999999999");
}

}  // namespace
}  // namespace rs::flightlog
