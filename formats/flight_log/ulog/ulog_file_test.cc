#include "formats/flight_log/ulog/ulog_file.h"
#include "tests/support/test_data.h"

#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "formats/flight_log/ulog/ulog_test_builder.h"
#include "formats/input_error.h"

namespace rs::ulog {
namespace {

using testing::Bytes;
using testing::UlogBuilder;

UlogFile Parse(const std::string& bytes, bool recover = false) {
  std::istringstream in(bytes);
  return ReadUlogFile(in, "mem.ulg", ReadOptions{recover});
}

// Byte offset of a parse failure, or -2 if it parsed.
int64_t FailOffset(const std::string& bytes, bool recover = false) {
  try {
    Parse(bytes, recover);
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "mem.ulg");
    return e.where().byte_offset;
  }
  return -2;
}

// A record of "pose": timestamp, int16[2] a, vec3 v, vec3[2] w, trailing padding.
std::string PoseRecord(uint64_t t, int16_t a0, int16_t a1, float base) {
  Bytes b;
  b.Put(t).Put(a0).Put(a1);
  for (int i = 0; i < 9; ++i) b.Put(base + i);
  return b.str();
}

UlogBuilder NominalLog() {
  UlogBuilder b(1000);
  b.Flags(0);
  b.Format("vec3:float x;float y;float z;");
  b.Format("pose:uint64_t timestamp;int16_t[2] a;vec3 v;vec3[2] w;uint8_t[3] _padding0;");
  b.Info("sys_name", "PX4").InfoInt32("time_ref_utc", -3600);
  b.InfoMultiple(false, "boot", "part1").InfoMultiple(true, "boot", "part2").InfoMultiple(false, "boot", "again");
  b.ParamInt("SYS_AUTOSTART", 4001).ParamFloat("MPC_XY_VEL", 5.5f).DefaultParamFloat(3, "MPC_XY_VEL", 12.0f);
  b.Subscribe(0, 7, "pose").Subscribe(1, 8, "pose");
  b.Data(7, PoseRecord(2000, -3, 4, 1.5f));
  b.Log('6', 2100, "hello");
  b.Data(8, PoseRecord(2500, 9, 9, 100.f));
  b.Sync();
  b.Dropout(42);
  b.Data(7, PoseRecord(3000, 5, 6, 2.5f) + std::string(3, '\0'));  // with the trailing padding written
  b.ParamFloat("MPC_XY_VEL", 7.25f);
  b.Tagged('3', 17, 3100, "tagged");
  return b;
}

TEST(UlogFile, Nominal) {
  const UlogFile f = Parse(NominalLog().str());
  EXPECT_EQ(f.version, 1);
  EXPECT_EQ(f.start_timestamp_us, 1000u);
  EXPECT_EQ(f.last_timestamp_us, 3000u);
  EXPECT_EQ(f.InfoString("sys_name"), "PX4");
  EXPECT_EQ(f.info.at("time_ref_utc").AsInt(), -3600);
  EXPECT_EQ(f.info.at("time_ref_utc").ToString(), "-3600");
  ASSERT_EQ(f.info_multiple.at("boot").size(), 2u);
  ASSERT_EQ(f.info_multiple.at("boot")[0].size(), 2u);
  EXPECT_EQ(f.info_multiple.at("boot")[0][1].ToString(), "part2");
  EXPECT_EQ(f.info_multiple.at("boot")[1][0].ToString(), "again");
  EXPECT_EQ(f.initial_params.at("SYS_AUTOSTART").i, 4001);
  EXPECT_FALSE(f.initial_params.at("SYS_AUTOSTART").is_float);
  EXPECT_FLOAT_EQ(f.initial_params.at("MPC_XY_VEL").f, 5.5f);
  EXPECT_FLOAT_EQ(f.default_params.at(0).at("MPC_XY_VEL").f, 12.0f);
  EXPECT_FLOAT_EQ(f.default_params.at(1).at("MPC_XY_VEL").f, 12.0f);
  ASSERT_EQ(f.changed_params.size(), 1u);
  EXPECT_EQ(f.changed_params[0].timestamp_us, 3000u);
  EXPECT_FLOAT_EQ(f.changed_params[0].value.f, 7.25f);
  ASSERT_EQ(f.messages.size(), 2u);
  EXPECT_EQ(f.messages[0].text, "hello");
  EXPECT_STREQ(f.messages[0].LevelName(), "INFO");
  EXPECT_TRUE(f.messages[1].tagged);
  EXPECT_EQ(f.messages[1].tag, 17);
  EXPECT_EQ(f.messages[1].timestamp_us, 3100u);
  EXPECT_STREQ(f.messages[1].LevelName(), "ERROR");
  ASSERT_EQ(f.dropouts.size(), 1u);
  EXPECT_EQ(f.dropouts[0].duration_ms, 42);
  EXPECT_EQ(f.dropouts[0].timestamp_us, 2500u);
  EXPECT_EQ(f.sync_count, 1);
  EXPECT_TRUE(f.skips.empty());

  ASSERT_EQ(f.topics.size(), 2u);
  const Topic* p = f.FindTopic("pose", 0);
  ASSERT_NE(p, nullptr);
  ASSERT_EQ(p->size(), 2u);
  EXPECT_EQ(p->record_size, 8u + 4u + 36u);
  EXPECT_EQ(p->max_record_size, p->record_size + 3);
  const std::vector<std::string> names = {"timestamp", "a[0]",   "a[1]",   "v.x",    "v.y",    "v.z",
                                          "w[0].x",    "w[0].y", "w[0].z", "w[1].x", "w[1].y", "w[1].z"};
  ASSERT_EQ(p->fields.size(), names.size());
  for (size_t i = 0; i < names.size(); ++i) EXPECT_EQ(p->fields[i].name, names[i]);
  EXPECT_EQ(p->TimestampUs(1), 3000u);
  EXPECT_EQ(p->IntValue(0, *p->FieldIndex("a[0]")), -3);
  EXPECT_EQ(p->IntValue(1, *p->FieldIndex("a[1]")), 6);
  EXPECT_FLOAT_EQ(p->Value(0, *p->FieldIndex("v.y")), 2.5f);
  EXPECT_FLOAT_EQ(p->Value(1, *p->FieldIndex("w[1].z")), 2.5f + 8);
  const Topic* p1 = f.FindTopic("pose", 1);
  ASSERT_NE(p1, nullptr);
  EXPECT_EQ(p1->size(), 1u);
  EXPECT_FLOAT_EQ(p1->Value(0, *p1->FieldIndex("v.x")), 100.f);
}

TEST(UlogFile, BadMagic) {
  std::string s = NominalLog().str();
  s[2] = 'X';
  EXPECT_EQ(FailOffset(s), 0);
  EXPECT_EQ(FailOffset("ULo"), 0);
}

TEST(UlogFile, Truncated) {
  const std::string full = NominalLog().str();
  // Message boundaries: a cut exactly there is a shorter valid log.
  std::vector<size_t> bounds;
  for (size_t pos = 16; pos < full.size();) {
    bounds.push_back(pos);
    pos += 3 + (static_cast<uint8_t>(full[pos]) | (static_cast<uint8_t>(full[pos + 1]) << 8));
  }
  for (size_t len = 0; len < full.size(); ++len) {
    const std::string cut = full.substr(0, len);
    const int64_t off = FailOffset(cut);
    if (len < 16) {
      EXPECT_EQ(off, 0) << len;
    } else if (std::find(bounds.begin(), bounds.end(), len) != bounds.end()) {
      EXPECT_EQ(off, -2) << len;
    } else {
      // Error at the start of the message that was cut.
      const size_t start = *(std::upper_bound(bounds.begin(), bounds.end(), len) - 1);
      EXPECT_EQ(off, static_cast<int64_t>(start)) << len;
      const UlogFile r = Parse(cut, /*recover=*/true);
      ASSERT_EQ(r.skips.size(), 1u) << len;
      EXPECT_EQ(r.skips[0].offset, static_cast<int64_t>(start));
      EXPECT_EQ(r.skips[0].bytes, static_cast<int64_t>(len - start));
    }
  }
}

TEST(UlogFile, GarbageRecoveredAtSync) {
  UlogBuilder b = NominalLog();
  const size_t garbage_at = b.size();
  b.Garbage(std::string("\x00\x00\x00\xff\xfe\x01\x02", 7));
  b.Sync();
  b.Data(7, PoseRecord(4000, 1, 2, 3.f));
  EXPECT_EQ(FailOffset(b.str()), static_cast<int64_t>(garbage_at));
  const UlogFile r = Parse(b.str(), true);
  ASSERT_EQ(r.skips.size(), 1u);
  EXPECT_EQ(r.skips[0].offset, static_cast<int64_t>(garbage_at));
  EXPECT_EQ(r.skips[0].bytes, 7);  // resumed at the sync message, a plausible header
  EXPECT_EQ(r.sync_count, 2);
  EXPECT_EQ(r.FindTopic("pose", 0)->size(), 3u);
  EXPECT_EQ(r.last_timestamp_us, 4000u);
}

TEST(UlogFile, BadDataMessageSkippedAlone) {
  UlogBuilder b = NominalLog();
  const size_t bad_at = b.size();
  b.Data(99, "xxxx");  // no subscription for msg_id 99
  b.Data(7, PoseRecord(5000, 1, 2, 3.f));
  EXPECT_EQ(FailOffset(b.str()), static_cast<int64_t>(bad_at));
  const UlogFile r = Parse(b.str(), true);
  ASSERT_EQ(r.skips.size(), 1u);
  EXPECT_EQ(r.skips[0].offset, static_cast<int64_t>(bad_at));
  EXPECT_EQ(r.skips[0].bytes, 3 + 6);
  EXPECT_EQ(r.FindTopic("pose", 0)->size(), 3u);
}

TEST(UlogFile, UnknownMessageTypeSkipped) {
  UlogBuilder b = NominalLog();
  b.Raw('X', "future");
  b.Data(7, PoseRecord(5000, 1, 2, 3.f));
  const UlogFile f = Parse(b.str());
  EXPECT_EQ(f.unknown_message_types.at('X'), 1);
  EXPECT_EQ(f.FindTopic("pose", 0)->size(), 3u);
}

TEST(UlogFile, RecursiveFormat) {
  UlogBuilder b(0);
  b.Format("a:uint64_t timestamp;b x;").Format("b:a y;");
  const size_t at = b.size();
  b.Subscribe(0, 1, "a");
  EXPECT_EQ(FailOffset(b.str()), static_cast<int64_t>(at));
}

TEST(UlogFile, HugeNestedFormat) {
  // 1000^3 floats if expanded blindly: must be refused, not allocated.
  UlogBuilder b(0);
  b.Format("l0:float[1000] f;").Format("l1:l0[1000] g;").Format("l2:uint64_t timestamp;l1[1000] h;");
  const size_t at = b.size();
  b.Subscribe(0, 1, "l2");
  EXPECT_EQ(FailOffset(b.str()), static_cast<int64_t>(at));
}

TEST(UlogFile, MalformedFormat) {
  UlogBuilder b(0);
  const size_t at = b.size();
  b.Format("t:uint64_t timestamp;float[x] bad;");
  EXPECT_EQ(FailOffset(b.str()), static_cast<int64_t>(at));
}

TEST(UlogFile, UnknownIncompatFlag) {
  UlogBuilder b(0);
  b.Flags(0x02);
  EXPECT_EQ(FailOffset(b.str()), 16);
  EXPECT_EQ(FailOffset(b.str(), true), 16);
}

TEST(UlogFile, AppendedData) {
  // Main log, a message cut by the start of appended data, then the appended part.
  UlogBuilder b(0);
  b.Flags(1, 0);  // placeholder offset, patched below
  b.Format("t:uint64_t timestamp;int32_t v;");
  b.Subscribe(0, 3, "t");
  b.Data(3, Bytes().Put<uint64_t>(10).Put<int32_t>(1).str());
  const size_t offset = b.size() + 5;  // cuts the next data message after 5 bytes
  b.Data(3, Bytes().Put<uint64_t>(20).Put<int32_t>(2).str());
  std::string s = b.str().substr(0, offset);
  UlogBuilder tail(0);
  tail.Data(3, Bytes().Put<uint64_t>(30).Put<int32_t>(3).str());
  s += tail.str().substr(16);
  const std::string off_bytes = Bytes().Put<uint64_t>(offset).str();
  s.replace(16 + 3 + 16, 8, off_bytes);
  const UlogFile f = Parse(s);
  ASSERT_EQ(f.appended_offsets.size(), 1u);
  EXPECT_EQ(f.appended_offsets[0], offset);
  EXPECT_EQ(f.messages_cut_at_appended_offset, 1);
  const Topic* t = f.FindTopic("t");
  ASSERT_NE(t, nullptr);
  ASSERT_EQ(t->size(), 2u);
  EXPECT_EQ(t->IntValue(1, 1), 3);

  s.replace(16 + 3 + 16, 8, Bytes().Put<uint64_t>(s.size() + 100).str());
  EXPECT_EQ(FailOffset(s), 16);  // offset beyond the end of the file
}

// Real samples: truncated and bit-flipped copies give an error with an offset
// (strict) or counted skips (recover), never a crash.
std::string SampleBytes(const char* name) {
  const auto p = rs::test::DataRoot() / "px4_ulog" / "test" / name;
  std::ifstream in(p, std::ios::binary);
  if (!in) return {};
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class UlogSampleDamage : public ::testing::TestWithParam<const char*> {};

TEST_P(UlogSampleDamage, TruncatedAndBitFlipped) {
  const std::string full = SampleBytes(GetParam());
  if (full.empty()) GTEST_SKIP() << "sample data absent: " << GetParam();
  const UlogFile ref = Parse(full);
  size_t ref_records = 0;
  for (const Topic& t : ref.topics) ref_records += t.size();

  std::mt19937_64 rng(1234);
  for (int k = 0; k < 6; ++k) {
    const size_t len = 16 + rng() % (full.size() - 16);
    const std::string cut = full.substr(0, len);
    const int64_t off = FailOffset(cut);
    if (off != -2) {
      EXPECT_GE(off, 16);
      EXPECT_LT(off, static_cast<int64_t>(len));
      const UlogFile r = Parse(cut, true);
      ASSERT_GE(r.skips.size(), 1u);
      // The cut message is the last skip; appended-data offsets now past the
      // end are reported first (and are what strict mode names, at the flags).
      EXPECT_TRUE(off == r.skips.back().offset || (off == 16 && r.skips.size() > 1)) << off;
      EXPECT_EQ(r.skips.back().offset + r.skips.back().bytes, static_cast<int64_t>(len));
    }
  }
  for (int k = 0; k < 12; ++k) {
    std::string flipped = full;
    for (int j = 0; j < 4; ++j) {
      const size_t at = 16 + rng() % (full.size() - 16);
      flipped[at] = static_cast<char>(flipped[at] ^ (1 << (rng() % 8)));
    }
    const int64_t off = FailOffset(flipped);
    EXPECT_TRUE(off == -2 || (off >= 16 && off < static_cast<int64_t>(full.size()))) << off;
    try {
      const UlogFile r = Parse(flipped, true);
      size_t records = 0;
      for (const Topic& t : r.topics) records += t.size();
      EXPECT_LE(records, ref_records + 64);  // a flip can at most re-frame a few messages
      for (const Skip& s : r.skips) {
        EXPECT_GE(s.offset, 16);
        EXPECT_LE(s.offset + s.bytes, static_cast<int64_t>(full.size()));
      }
    } catch (const InputError& e) {
      // Only unrecoverable header damage (flags, formats) may still throw.
      EXPECT_GE(e.where().byte_offset, 16);
    }
  }
  // A flipped message type in mid-file is found exactly where it is.
  const size_t limit = ref.appended_offsets.empty() ? full.size() : ref.appended_offsets[0];
  size_t pos = 16, target = 0;
  while (pos + 3 <= limit) {
    if (pos > limit / 2 && full[pos + 2] == 'D') {
      target = pos;
      break;
    }
    pos += 3 + (static_cast<uint8_t>(full[pos]) | (static_cast<uint8_t>(full[pos + 1]) << 8));
  }
  ASSERT_GT(target, 0u);
  std::string broken = full;
  broken[target + 2] = '\x01';
  EXPECT_EQ(FailOffset(broken), static_cast<int64_t>(target));
  const UlogFile r = Parse(broken, true);
  ASSERT_GE(r.skips.size(), 1u);
  EXPECT_EQ(r.skips[0].offset, static_cast<int64_t>(target));
  size_t records = 0;
  for (const Topic& t : r.topics) records += t.size();
  EXPECT_EQ(records, ref_records - 1);
}

INSTANTIATE_TEST_SUITE_P(Samples, UlogSampleDamage,
                         ::testing::Values("sample.ulg", "sample_appended_multiple.ulg", "sample_log_small.ulg",
                                           "sample_logging_tagged_and_default_params.ulg", "sample_px4_events.ulg"));

}  // namespace
}  // namespace rs::ulog
