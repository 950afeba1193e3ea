// Conformance with pyulog: the expected outputs of `ulog_info -v` and
// `ulog_messages` stored beside the sample logs in px4_ulog/test are parsed
// here and compared with what our reader decodes.

#include <cstdio>
#include "tests/support/test_data.h"
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "formats/flight_log/ulog/ulog_file.h"

namespace rs::ulog {
namespace {

std::filesystem::path SampleDir() { return rs::test::DataRoot() / "px4_ulog" / "test"; }

std::vector<std::string> ReadLines(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

std::string Hms(uint64_t us) {
  const uint64_t s = us / 1000000;
  return fmt::format("{}:{:02d}:{:02d}", s / 3600, (s / 60) % 60, s % 60);
}

// Python 3 repr() of a str (what pyulog prints inside info_multiple lists).
std::string PyRepr(const std::string& s) {
  const bool has_single = s.find('\'') != std::string::npos, has_double = s.find('"') != std::string::npos;
  const char q = has_single && !has_double ? '"' : '\'';
  std::string out(1, q);
  for (unsigned char c : s) {
    if (c == '\\')
      out += "\\\\";
    else if (c == static_cast<unsigned char>(q))
      out += std::string("\\") + static_cast<char>(q);
    else if (c == '\n')
      out += "\\n";
    else if (c == '\r')
      out += "\\r";
    else if (c == '\t')
      out += "\\t";
    else if (c < 0x20 || c == 0x7f)
      out += fmt::format("\\x{:02x}", c);
    else
      out += static_cast<char>(c);
  }
  return out + q;
}

// Everything pyulog's info printer shows, formatted the same way.
struct InfoExpectation {
  std::string start_line;
  std::string dropout_line;
  std::map<std::string, std::string> info;
  std::map<std::string, std::string> info_multiple;  // key -> repr of the list of lists
  std::vector<std::string> topics;                   // "name multi size count total"
};

InfoExpectation ParseInfoFile(const std::filesystem::path& p) {
  InfoExpectation e;
  const auto lines = ReadLines(p);
  enum { kHead, kInfo, kMulti, kTopics } section = kHead;
  for (const std::string& l : lines) {
    if (l.rfind("Logging start time:", 0) == 0)
      e.start_line = l;
    else if (l.rfind("Dropouts:", 0) == 0 || l == "No Dropouts")
      e.dropout_line = l;
    else if (l == "Info Messages:")
      section = kInfo;
    else if (l == "Info Multiple Messages:")
      section = kMulti;
    else if (l.rfind("Name (multi id", 0) == 0)
      section = kTopics;
    else if (l.rfind("SW Version:", 0) == 0 || l.empty())
      continue;
    else if (section == kInfo || section == kMulti) {
      const size_t colon = l.find(": ");
      if (l.size() < 2 || l[0] != ' ' || colon == std::string::npos) {
        ADD_FAILURE() << "unparsed line in " << p << ": " << l;
        continue;
      }
      (section == kInfo ? e.info : e.info_multiple)[l.substr(1, colon - 1)] = l.substr(colon + 2);
    } else if (section == kTopics) {
      char name[256];
      int multi, size;
      long long count, total;
      if (std::sscanf(l.c_str(), " %255s (%d, %d) %lld %lld", name, &multi, &size, &count, &total) != 5) {
        ADD_FAILURE() << "unparsed topic line: " << l;
        continue;
      }
      e.topics.push_back(fmt::format("{} {} {} {} {}", name, multi, size, count, total));
    }
  }
  return e;
}

InfoExpectation Describe(const UlogFile& f) {
  InfoExpectation e;
  e.start_line = fmt::format("Logging start time: {}, duration: {}", Hms(f.start_timestamp_us),
                             Hms(f.last_timestamp_us - f.start_timestamp_us));
  if (f.dropouts.empty()) {
    e.dropout_line = "No Dropouts";
  } else {
    long long sum = 0;
    int max = 0;
    for (const Dropout& d : f.dropouts) {
      sum += d.duration_ms;
      max = std::max<int>(max, d.duration_ms);
    }
    e.dropout_line = fmt::format("Dropouts: count: {}, total duration: {:.1f} s, max: {} ms, mean: {} ms",
                                 f.dropouts.size(), sum / 1000.0, max, sum / static_cast<long long>(f.dropouts.size()));
  }
  for (const auto& [k, v] : f.info) e.info[k] = v.ToString();
  for (const auto& [k, lists] : f.info_multiple) {
    std::string s = "[";
    for (size_t i = 0; i < lists.size(); ++i) {
      s += i ? ", [" : "[";
      for (size_t j = 0; j < lists[i].size(); ++j) s += (j ? ", " : "") + PyRepr(lists[i][j].ToString());
      s += "]";
    }
    e.info_multiple[k] = s + "]";
  }
  for (const Topic& t : f.topics) {
    uint32_t size = 0;
    for (const FlatField& ff : t.fields) size += BaseTypeSize(ff.type);
    e.topics.push_back(fmt::format("{} {} {} {} {}", t.name, t.multi_id, size, t.size(), size * t.size()));
  }
  return e;
}

class PyulogInfo : public testing::TestWithParam<const char*> {};

TEST_P(PyulogInfo, Nominal) {
  const auto dir = SampleDir();
  const auto ulg = dir / (std::string(GetParam()) + ".ulg");
  const auto txt = dir / (std::string(GetParam()) + "_info.txt");
  if (!std::filesystem::exists(ulg) || !std::filesystem::exists(txt)) GTEST_SKIP() << "sample data absent: " << ulg;
  const InfoExpectation want = ParseInfoFile(txt);
  const InfoExpectation got = Describe(ReadUlogFile(ulg));
  EXPECT_EQ(got.start_line, want.start_line);
  EXPECT_EQ(got.dropout_line, want.dropout_line);
  ASSERT_FALSE(want.info.empty());
  EXPECT_EQ(got.info.size(), want.info.size());
  for (const auto& [k, v] : want.info) {
    auto it = got.info.find(k);
    ASSERT_NE(it, got.info.end()) << "missing info " << k;
    EXPECT_EQ(it->second, v) << "info " << k;
  }
  EXPECT_EQ(got.info_multiple.size(), want.info_multiple.size());
  for (const auto& [k, v] : want.info_multiple) {
    auto it = got.info_multiple.find(k);
    ASSERT_NE(it, got.info_multiple.end()) << "missing info_multiple " << k;
    EXPECT_EQ(it->second, v) << "info_multiple " << k;
  }
  ASSERT_FALSE(want.topics.empty());
  EXPECT_EQ(got.topics, want.topics);
}

INSTANTIATE_TEST_SUITE_P(Samples, PyulogInfo, testing::Values("sample", "sample_appended_multiple"));

class PyulogMessages : public testing::TestWithParam<const char*> {};

TEST_P(PyulogMessages, Nominal) {
  const auto dir = SampleDir();
  const auto ulg = dir / (std::string(GetParam()) + ".ulg");
  const auto txt = dir / (std::string(GetParam()) + "_messages.txt");
  if (!std::filesystem::exists(ulg) || !std::filesystem::exists(txt)) GTEST_SKIP() << "sample data absent: " << ulg;
  const auto want = ReadLines(txt);
  const UlogFile f = ReadUlogFile(ulg);
  // pyulog prints untagged strings; for PX4 logs it drops those ending in a
  // tab (they duplicate an event) and merges in decoded events, which need
  // the events metadata we do not decode: those lines may be extra on its side.
  const bool px4 = f.InfoString("sys_name") == "PX4";
  std::vector<std::string> got;
  for (const LogMessage& m : f.messages) {
    if (m.tagged || (px4 && !m.text.empty() && m.text.back() == '\t')) continue;
    got.push_back(fmt::format("{} {}: {}", Hms(m.timestamp_us), m.LevelName(), m.text));
  }
  const Topic* events = f.FindTopic("event");
  if (!events) {
    EXPECT_EQ(got, want);
    return;
  }
  size_t j = 0;
  for (const std::string& g : got) {
    while (j < want.size() && want[j] != g) ++j;
    ASSERT_LT(j, want.size()) << "logged string not in pyulog's output (or out of order): " << g;
    ++j;
  }
  EXPECT_LE(want.size() - got.size(), events->size()) << "more extra lines than logged events";
  EXPECT_GE(got.size(), 3u);
}

INSTANTIATE_TEST_SUITE_P(Samples, PyulogMessages,
                         testing::Values("sample", "sample_appended_multiple", "sample_log_small",
                                         "sample_logging_tagged_and_default_params", "sample_px4_events"));

}  // namespace
}  // namespace rs::ulog
