#include "formats/flight_log/track_sort.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

GnssFix Fix(int64_t t_ns, int64_t pos) {
  GnssFix f;
  f.t_ns = t_ns;
  f.source_pos = pos;
  return f;
}

TEST(TrackSort, BackwardsTimeIsSortedAndLocatedByLine) {
  FlightTrack t;
  t.source_path = "log.csv";
  t.format = "csv";
  t.fixes = {Fix(100, 4), Fix(300, 5), Fix(200, 6), Fix(400, 7)};
  flightlog::SortTrackByTime(&t);
  ASSERT_EQ(t.fixes.size(), 4u);
  EXPECT_EQ(t.fixes[1].t_ns, 200);
  EXPECT_EQ(t.fixes[1].source_pos, 6);
  ASSERT_EQ(t.notes.size(), 1u);
  EXPECT_EQ(t.notes[0],
            "time goes backwards (1 fixes, 0 attitude, 0 camera events earlier than the record before them; sorted "
            "by time); fix at log.csv:6 is 0.000 s earlier than the one before it (at log.csv:5)");
}

TEST(TrackSort, BinaryLogsNameTheByteAndInOrderTracksHaveNoNote) {
  FlightTrack t;
  t.source_path = "log.bin";
  t.format = "ardupilot-dataflash";
  t.attitude = {AttitudeSample{2'000'000'000}, AttitudeSample{500'000'000}};
  t.attitude[0].source_pos = 1200;
  t.attitude[1].source_pos = 1245;
  flightlog::SortTrackByTime(&t);
  ASSERT_EQ(t.notes.size(), 1u);
  EXPECT_NE(t.notes[0].find("attitude sample at log.bin @ byte 1245 is 1.500 s earlier than the one before it "
                            "(at log.bin @ byte 1200)"),
            std::string::npos)
      << t.notes[0];
  flightlog::SortTrackByTime(&t);
  EXPECT_EQ(t.notes.size(), 1u) << "sorted: nothing more to say";
}

}  // namespace
}  // namespace rs
