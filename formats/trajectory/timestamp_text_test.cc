#include "formats/trajectory/timestamp_text.h"

#include <cstdint>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace rs {
namespace {

int64_t Ns(const char* text) {
  const SecondsParseResult r = ParseSecondsToNs(text);
  EXPECT_TRUE(r.t_ns.has_value()) << text;
  return r.t_ns.value_or(-42);
}

TEST(ParseSecondsToNs, Nominal) {
  // Epoch-scale times keep every digit (a double would round the last ones).
  EXPECT_EQ(Ns("1403715529.112143517"), INT64_C(1403715529112143517));
  EXPECT_EQ(Ns("1.403715529112143517e+09"), INT64_C(1403715529112143517));
  EXPECT_EQ(Ns("1341847980.7900"), INT64_C(1341847980790000000));
  EXPECT_EQ(Ns("1.037359e-01"), INT64_C(103735900));
  EXPECT_EQ(Ns("0.000000e+00"), 0);
  EXPECT_EQ(Ns("0.000000001"), 1);
  EXPECT_EQ(Ns("-0.000000001"), -1);
  EXPECT_EQ(Ns("+5"), INT64_C(5000000000));
  EXPECT_EQ(Ns("5."), INT64_C(5000000000));
  EXPECT_EQ(Ns(".5"), INT64_C(500000000));
  EXPECT_EQ(Ns("12E-9"), 12);
  EXPECT_EQ(Ns("1e9"), INT64_C(1000000000000000000));
  EXPECT_EQ(Ns("0000000000000000000000001.5"), INT64_C(1500000000));
  // A double holds ~16 significant digits, so the same text through double misses the exact ns.
  EXPECT_NE(static_cast<int64_t>(1403715529.112143517 * 1e9), INT64_C(1403715529112143517));
}

TEST(ParseSecondsToNs, Rounding) {
  EXPECT_EQ(Ns("0.0000000014"), 1);
  EXPECT_EQ(Ns("0.0000000015"), 2);  // halves away from zero
  EXPECT_EQ(Ns("-0.0000000015"), -2);
  EXPECT_EQ(Ns("0.00000000049999999999"), 0);
  EXPECT_EQ(Ns("1e-30"), 0);
  EXPECT_EQ(Ns("0.1234567894999e1"), INT64_C(1234567895));
  EXPECT_EQ(Ns("1.0000000005e-1"), 100000000);  // 100000000.05 ns -> 100000000
}

TEST(ParseSecondsToNs, Limits) {
  EXPECT_EQ(Ns("9223372036.854775807"), std::numeric_limits<int64_t>::max());
  EXPECT_EQ(Ns("-9223372036.854775808"), std::numeric_limits<int64_t>::min());
  EXPECT_EQ(ParseSecondsToNs("9223372036.854775808").error, SecondsParseError::kOverflow);
  EXPECT_FALSE(ParseSecondsToNs("9223372036.854775808").t_ns);
  EXPECT_FALSE(ParseSecondsToNs("9223372036.8547758075").t_ns);  // rounds past the limit
  EXPECT_FALSE(ParseSecondsToNs("1e10").t_ns);
  EXPECT_FALSE(ParseSecondsToNs("1e999999999999").t_ns);
  EXPECT_EQ(Ns("0e999999999999"), 0);
  EXPECT_EQ(Ns("1e-999999999999"), 0);
}

TEST(ParseSecondsToNs, Malformed) {
  for (const char* bad : {"", "-", ".", "e5", "1e", "1e+", "1.2.3", "1,5", " 1", "1 ", "0x10", "nan", "inf", "1..2",
                          "1e5.5", "--1", "+-1", "1_000"}) {
    const SecondsParseResult r = ParseSecondsToNs(bad);
    EXPECT_FALSE(r.t_ns.has_value()) << "'" << bad << "'";
    EXPECT_EQ(r.error, SecondsParseError::kSyntax) << bad;
  }
}

TEST(FormatNsAsSeconds, RoundTrip) {
  EXPECT_EQ(FormatNsAsSeconds(INT64_C(1403715529112143517)), "1403715529.112143517");
  EXPECT_EQ(FormatNsAsSeconds(-1), "-0.000000001");
  EXPECT_EQ(FormatNsAsSeconds(0), "0.000000000");
  std::mt19937_64 rng(7);
  for (int i = 0; i < 10000; ++i) {
    const int64_t t = static_cast<int64_t>(rng());
    ASSERT_EQ(Ns(FormatNsAsSeconds(t).c_str()), t);
  }
  for (int64_t t : {std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::max()}) {
    EXPECT_EQ(Ns(FormatNsAsSeconds(t).c_str()), t);
  }
}

}  // namespace
}  // namespace rs
