#include "survey/progress.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <thread>

namespace rs {
namespace {

std::string Drain(std::FILE* f) {
  std::rewind(f);
  std::string s;
  char buf[512];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
  return s;
}

TEST(Progress, LineShowsDoneTotalRateAndEta) {
  std::FILE* f = std::tmpfile();
  Progress p(Progress::Mode::kLog, f);
  p.Start("disparity", 40);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  p.Advance(10);
  const std::string line = p.Line();
  EXPECT_EQ(line.rfind("disparity 10/40 frames (25%)", 0), 0u) << line;
  EXPECT_NE(line.find("frames/s"), std::string::npos) << line;
  EXPECT_NE(line.find("ETA"), std::string::npos) << line;
  p.Finish();
  const std::string out = Drain(f);
  EXPECT_NE(out.find("[progress] disparity 10/40"), std::string::npos) << "log mode writes plain lines: " << out;
  EXPECT_EQ(out.find('\r'), std::string::npos) << "no carriage returns in logs";
  std::fclose(f);
}

TEST(Progress, TerminalRedrawsInPlace) {
  std::FILE* f = std::tmpfile();
  Progress p(Progress::Mode::kTerminal, f);
  p.Start("damage", 2);
  p.Advance(2);
  p.Finish();
  const std::string out = Drain(f);
  EXPECT_NE(out.find("\r"), std::string::npos) << out;
  EXPECT_NE(out.find("damage 2/2"), std::string::npos) << out;
  std::fclose(f);
}

TEST(Progress, QuietWritesNothing) {
  std::FILE* f = std::tmpfile();
  Progress p(Progress::Mode::kQuiet, f);
  p.Start("x", 1);
  p.Advance();
  p.Finish();
  EXPECT_TRUE(Drain(f).empty());
  std::fclose(f);
}

}  // namespace
}  // namespace rs
