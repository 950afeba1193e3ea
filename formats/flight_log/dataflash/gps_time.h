#pragma once
// GPS time (week + milliseconds of week) to UTC, with the GPS-UTC leap-second
// table. GPS time runs ahead of UTC by the leap seconds inserted since the GPS
// epoch (1980-01-06): 16 s from mid-2012, 17 s from mid-2015, 18 s since 2017.

#include <cstdint>
#include <optional>

namespace rs::dataflash {

/// Unix time (UTC seconds) of the GPS epoch, 1980-01-06 00:00:00.
inline constexpr int64_t kGpsEpochUnixS = 315964800;

/// GPS-UTC offset in seconds in effect at `gps_s` seconds after the GPS epoch.
/// Leap seconds announced after 2017-01-01 are not in the table (none so far).
int GpsUtcLeapSeconds(int64_t gps_s);

/// GPS week number (full, not modulo 1024) and milliseconds of week to Unix
/// UTC nanoseconds; nullopt outside week 0..9999 or ms 0..604799999.
std::optional<int64_t> GpsWeekMsToUtcNs(int64_t week, int64_t ms_of_week);

}  // namespace rs::dataflash
