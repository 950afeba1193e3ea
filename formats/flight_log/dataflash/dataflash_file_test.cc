#include "formats/flight_log/dataflash/dataflash_file.h"

#include <cmath>
#include <sstream>

#include <gtest/gtest.h>

#include "formats/flight_log/dataflash/dataflash_test_builder.h"
#include "formats/flight_log/dataflash/gps_time.h"
#include "formats/input_error.h"

namespace rs::dataflash {
namespace {

using testing::DataflashBuilder;
using testing::Payload;

DataflashFile Parse(const std::string& bytes) {
  std::istringstream in(bytes);
  return ReadDataflashFile(in, "mem.bin");
}

// Two message types using every format character (a format holds at most 16).
const char kAllFormat[] = "bBhHiIfdnNZcCeEL";
const char kAllColumns[] = "b,B,h,H,i,I,f,d,n,N,Z,c,C,e,E,L";
constexpr uint8_t kAllLength = 3 + 1 + 1 + 2 + 2 + 4 + 4 + 4 + 8 + 4 + 16 + 64 + 2 + 2 + 4 + 4 + 4;
constexpr uint8_t kRestLength = 3 + 1 + 8 + 8 + 64;

std::string AllPayload(int8_t b) {
  Payload p;
  p.Put<int8_t>(b).Put<uint8_t>(200).Put<int16_t>(-3000).Put<uint16_t>(60000).Put<int32_t>(-100000);
  p.Put<uint32_t>(4000000000u).Put<float>(1.25f).Put<double>(-2.5e10).Text("abcd", 4).Text("sixteen", 16);
  p.Text("a longer text field", 64).Put<int16_t>(-1234).Put<uint16_t>(4321).Put<int32_t>(-123456);
  p.Put<uint32_t>(654321u).Put<int32_t>(428500000);
  return p.str();
}

std::string RestPayload() {
  Payload p;
  p.Put<uint8_t>(5).Put<int64_t>(-9000000000LL).Put<uint64_t>(18000000000000000000ull);
  for (int i = 0; i < 32; ++i) p.Put<int16_t>(static_cast<int16_t>(i));
  return p.str();
}

TEST(DataflashFile, Nominal) {
  DataflashBuilder b;
  b.Fmt(200, kAllLength, "ALLT", kAllFormat, kAllColumns);
  b.Fmt(204, kRestLength, "REST", "MqQa", "M,q,Q,a");
  b.Message(204, RestPayload());
  b.Fmt(201, 3 + 8 + 1 + 64, "UNIT", "QbZ", "TimeUS,Id,Label");
  b.Fmt(202, 3 + 8 + 1 + 8, "MULT", "Qbd", "TimeUS,Id,Mult");
  b.Fmt(203, 3 + 8 + 1 + 16 + 16, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds");
  b.Message(200, AllPayload(-7));
  b.Message(201, Payload().Put<uint64_t>(1).Put<int8_t>('d').Text("deg", 64).str());
  b.Message(202, Payload().Put<uint64_t>(1).Put<int8_t>('G').Put<double>(1e-7).str());
  b.Message(
      203,
      Payload().Put<uint64_t>(2).Put<uint8_t>(200).Text("---------------d", 16).Text("---------------G", 16).str());
  b.Message(200, AllPayload(8));
  const DataflashFile f = Parse(b.str());
  EXPECT_EQ(f.skipped_bytes, 0);
  EXPECT_EQ(f.rejected_formats, 0);
  const MessageType* m = f.Find("ALLT");
  ASSERT_NE(m, nullptr);
  ASSERT_EQ(m->size(), 2u);
  EXPECT_EQ(m->offsets[0], 6 * 89 + kRestLength);
  auto v = [&](const char* col) { return m->Value(0, *m->ColumnIndex(col)); };
  EXPECT_EQ(v("b"), -7);
  EXPECT_EQ(m->Int(1, 0), 8);
  EXPECT_EQ(v("B"), 200);
  EXPECT_EQ(v("h"), -3000);
  EXPECT_EQ(v("H"), 60000);
  EXPECT_EQ(v("i"), -100000);
  EXPECT_EQ(v("I"), 4000000000.0);
  EXPECT_EQ(v("f"), 1.25);
  EXPECT_EQ(v("d"), -2.5e10);
  EXPECT_EQ(m->Text(0, *m->ColumnIndex("n")), "abcd");
  EXPECT_EQ(m->Text(0, *m->ColumnIndex("N")), "sixteen");
  EXPECT_EQ(m->Text(0, *m->ColumnIndex("Z")), "a longer text field");
  EXPECT_TRUE(std::isnan(v("Z")));
  EXPECT_DOUBLE_EQ(v("c"), -12.34);
  EXPECT_DOUBLE_EQ(v("C"), 43.21);
  EXPECT_DOUBLE_EQ(v("e"), -1234.56);
  EXPECT_DOUBLE_EQ(v("E"), 6543.21);
  EXPECT_NEAR(v("L"), 42.85, 1e-12);
  const MessageType* r = f.Find("REST");
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->Value(0, 0), 5);
  EXPECT_EQ(r->Int(0, 1), -9000000000LL);
  EXPECT_EQ(r->Value(0, 2), 18000000000000000000.0);
  EXPECT_TRUE(std::isnan(r->Value(0, 3)));  // 'a' (int16[32]) has no scalar value
  EXPECT_EQ(m->columns[*m->ColumnIndex("L")].unit, "deg");
  EXPECT_DOUBLE_EQ(m->columns[*m->ColumnIndex("L")].fmtu_multiplier, 1e-7);
  EXPECT_EQ(m->columns[0].unit, "");
}

TEST(DataflashFile, GarbageSkippedAndCounted) {
  DataflashBuilder b;
  b.Fmt(200, kAllLength, "ALLT", kAllFormat, kAllColumns);
  b.Message(200, AllPayload(1));
  const size_t g1 = b.size();
  b.Garbage(std::string("\xA3\x01\x02\xA3\x95\x07xyz", 9));  // incl. a header with an undefined type
  b.Message(200, AllPayload(2));
  const size_t g2 = b.size();
  b.Garbage(std::string(100, '\xff'));
  b.Message(200, AllPayload(3));
  const DataflashFile f = Parse(b.str());
  EXPECT_EQ(f.skipped_bytes, 109);
  EXPECT_EQ(f.skip_runs, 2);
  ASSERT_EQ(f.skips.size(), 2u);
  EXPECT_EQ(f.skips[0].offset, static_cast<int64_t>(g1));
  EXPECT_EQ(f.skips[0].bytes, 9);
  EXPECT_EQ(f.skips[1].offset, static_cast<int64_t>(g2));
  EXPECT_EQ(f.skips[1].bytes, 100);
  ASSERT_EQ(f.Find("ALLT")->size(), 3u);
  EXPECT_EQ(f.Find("ALLT")->Int(2, 0), 3);
}

TEST(DataflashFile, TruncatedTail) {
  DataflashBuilder b;
  b.Fmt(200, kAllLength, "ALLT", kAllFormat, kAllColumns);
  b.Message(200, AllPayload(1));
  const size_t last = b.size();
  b.Message(200, AllPayload(2));
  for (size_t cut = last + 1; cut < b.size(); cut += 17) {
    const DataflashFile f = Parse(b.str().substr(0, cut));
    EXPECT_EQ(f.Find("ALLT")->size(), 1u);
    ASSERT_EQ(f.skips.size(), 1u);
    EXPECT_EQ(f.skips[0].offset, static_cast<int64_t>(last));
    EXPECT_EQ(f.skipped_bytes, static_cast<int64_t>(cut - last));
  }
}

TEST(DataflashFile, UnusableFormat) {
  DataflashBuilder b;
  b.Fmt(210, 3 + 4, "BADF", "Ix", "A,B");    // 'x' is no format character
  b.Fmt(211, 3 + 2, "SHRT", "I", "TimeMS");  // declared length shorter than the columns
  b.Message(210, "abcd");
  const DataflashFile f = Parse(b.str());
  EXPECT_EQ(f.rejected_formats, 2);
  EXPECT_EQ(f.Find("BADF"), nullptr);
  EXPECT_EQ(f.skipped_bytes, 3 + 4);
}

TEST(DataflashFile, NotDataflash) {
  try {
    Parse(std::string(500, 'x'));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().byte_offset, 0);
    EXPECT_EQ(e.where().path, "mem.bin");
  }
}

TEST(GpsTime, Nominal) {
  EXPECT_EQ(GpsUtcLeapSeconds(0), 0);
  EXPECT_EQ(GpsUtcLeapSeconds(1167264017), 17);  // 2016-12-31 23:59:60 UTC
  EXPECT_EQ(GpsUtcLeapSeconds(1167264018), 18);  // 2017-01-01 00:00:00 UTC
  // Expected values computed independently (Python datetime).
  EXPECT_EQ(*GpsWeekMsToUtcNs(1820, 388800000), 1417089584000LL * 1000000);
  EXPECT_EQ(*GpsWeekMsToUtcNs(1817, 400000123), 1415286384123LL * 1000000);
  EXPECT_EQ(*GpsWeekMsToUtcNs(2086, 0), 1577577582000LL * 1000000);
  EXPECT_FALSE(GpsWeekMsToUtcNs(65535, 0).has_value());  // corrupt week: refused, no overflow
  EXPECT_FALSE(GpsWeekMsToUtcNs(2086, 604800000).has_value());
}

}  // namespace
}  // namespace rs::dataflash
