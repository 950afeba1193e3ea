#include "stages/ingest/flight_log_check.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

constexpr int64_t kS = 1'000'000'000;

// Fixes every 0.5 s from t = 0 to 10 s (log clock); camera events at the frames' log times.
FlightTrack Track(const std::vector<int64_t>& event_t_ns = {}) {
  FlightTrack t;
  for (int i = 0; i <= 20; ++i) {
    GnssFix f;
    f.t_ns = i * kS / 2;
    f.lat_deg = 46.0 + i * 1e-6;
    f.lon_deg = 14.0;
    f.fix_type = 3;
    t.fixes.push_back(f);
  }
  for (int64_t e : event_t_ns) t.camera_events.push_back({e});
  return t;
}

// Eight frames 0.25 s apart, from camera time `start`.
std::vector<int64_t> Frames(int64_t start) {
  std::vector<int64_t> t;
  for (int i = 0; i < 8; ++i) t.push_back(start + i * kS / 4);
  return t;
}

std::string Errors(const ProblemList& p) {
  std::string s;
  for (const auto& i : p.items())
    if (i.severity == InputProblem::Severity::kError) s += i.message + "\n";
  return s;
}

TEST(FlightLogCheck, FramesInsideWithoutOffsetUseZero) {
  ProblemList p;
  const auto a = CheckFlightLog(Track(), "log.csv", nlohmann::json::object(), Frames(2 * kS), IngestOptions{}, p);
  ASSERT_TRUE(a) << Errors(p);
  EXPECT_EQ(a->offset_ns, 0);
  EXPECT_FALSE(p.HasErrors());
}

// A configured offset that moves the frames outside the log is an error naming the option, the
// log and both ranges, even when the camera events would give a working estimate.
TEST(FlightLogCheck, ConfiguredOffsetOutsideTheLogIsAnError) {
  const std::vector<int64_t> frames = Frames(2 * kS);
  ProblemList p;
  const auto a = CheckFlightLog(Track(frames), "log.csv", {{"clock_offset_s", 100}}, frames, IngestOptions{}, p);
  EXPECT_FALSE(a);
  ASSERT_EQ(p.ErrorCount(), 1);
  const std::string e = Errors(p);
  EXPECT_NE(e.find("inputs.flight_log.clock_offset_s = 100 s"), std::string::npos) << e;
  EXPECT_NE(e.find("8 frames at log time -98.000 to -96.250 s, log from 0.000 to 10.000 s"), std::string::npos) << e;
  EXPECT_NE(e.find("suggest clock_offset_s = 0.000"), std::string::npos) << e;
  EXPECT_EQ(p.items().front().where.path, "log.csv");
}

// A configured offset inside the log is refined by a confident estimate, with a warning giving both.
TEST(FlightLogCheck, ConfidentEstimateRefinesAConfiguredOffsetVisibly) {
  const std::vector<int64_t> frames = Frames(2 * kS + kS / 10);  // camera = log + 0.1 s
  const std::vector<int64_t> events = Frames(2 * kS);
  ProblemList p;
  const auto a = CheckFlightLog(Track(events), "log.csv", {{"clock_offset_s", 0.12}}, frames, IngestOptions{}, p);
  ASSERT_TRUE(a) << Errors(p);
  EXPECT_EQ(a->offset_ns, kS / 10);
  EXPECT_EQ(a->report["method"], "camera-events");
  ASSERT_EQ(p.WarningCount(), 1);
  EXPECT_NE(p.items().front().message.find("instead of the configured inputs.flight_log.clock_offset_s = 0.120 s"),
            std::string::npos)
      << p.items().front().message;
}

// Without a configured offset, frames outside the log fail with the ranges and the option to set.
TEST(FlightLogCheck, TooFewFramesInsideIsAnError) {
  IngestOptions o;
  o.estimate_clock_offset = false;
  ProblemList p;
  const auto a = CheckFlightLog(Track(), "log.csv", nlohmann::json::object(), Frames(9 * kS + kS / 2), o, p);
  EXPECT_FALSE(a);  // 9.5 .. 11.25 s: 3 of 8 inside
  EXPECT_NE(Errors(p).find("only 38% of frames fall inside"), std::string::npos) << Errors(p);
  EXPECT_NE(Errors(p).find("inputs.flight_log.clock_offset_s"), std::string::npos);
  ProblemList half;
  o.min_in_span_fraction = 0.375;  // exactly 3 of 8 inside is enough
  EXPECT_TRUE(CheckFlightLog(Track(), "log.csv", nlohmann::json::object(), Frames(9 * kS + kS / 2), o, half));
}

TEST(FlightLogCheck, NotesAreWarningsAndNoFixIsAnError) {
  FlightTrack t;
  t.notes = {"log cut short"};
  ProblemList p;
  EXPECT_FALSE(CheckFlightLog(t, "log.ulg", nlohmann::json::object(), Frames(0), IngestOptions{}, p));
  ASSERT_EQ(p.items().size(), 2u);
  EXPECT_EQ(p.items()[0].severity, InputProblem::Severity::kWarning);
  EXPECT_EQ(p.items()[0].message, "log cut short");
  EXPECT_EQ(p.items()[1].message, "flight log has no GNSS fix");
}

}  // namespace
}  // namespace rs
