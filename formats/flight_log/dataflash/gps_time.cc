#include "formats/flight_log/dataflash/gps_time.h"

namespace rs::dataflash {
namespace {

// UTC instants (Unix seconds) from which GPS-UTC became 1, 2, ... 18 s.
constexpr int64_t kLeapStartsUnixS[] = {
    362793600,   // 1981-07-01
    394329600,   // 1982-07-01
    425865600,   // 1983-07-01
    489024000,   // 1985-07-01
    567993600,   // 1988-01-01
    631152000,   // 1990-01-01
    662688000,   // 1991-01-01
    709948800,   // 1992-07-01
    741484800,   // 1993-07-01
    773020800,   // 1994-07-01
    820454400,   // 1996-01-01
    867715200,   // 1997-07-01
    915148800,   // 1999-01-01
    1136073600,  // 2006-01-01
    1230768000,  // 2009-01-01
    1341100800,  // 2012-07-01
    1435708800,  // 2015-07-01
    1483228800,  // 2017-01-01
};

}  // namespace

int GpsUtcLeapSeconds(int64_t gps_s) {
  // Leap n starts at UTC instant T_n, i.e. at GPS time (T_n - epoch) + n.
  const int n_max = static_cast<int>(sizeof(kLeapStartsUnixS) / sizeof(kLeapStartsUnixS[0]));
  for (int n = n_max; n >= 1; --n) {
    if (gps_s >= kLeapStartsUnixS[n - 1] - kGpsEpochUnixS + n) return n;
  }
  return 0;
}

std::optional<int64_t> GpsWeekMsToUtcNs(int64_t week, int64_t ms_of_week) {
  // The range keeps the nanosecond result far from int64 overflow (week 9999 is in 2171).
  if (week < 0 || week > 9999 || ms_of_week < 0 || ms_of_week >= 604800000LL) return std::nullopt;
  const int64_t gps_ms = week * 604800000LL + ms_of_week;
  const int64_t leap_s = GpsUtcLeapSeconds(gps_ms / 1000);
  return (kGpsEpochUnixS * 1000 + gps_ms - leap_s * 1000) * 1000000LL;
}

}  // namespace rs::dataflash
