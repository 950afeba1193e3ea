#pragma once
// Calendar date/time text -> int64 nanoseconds, without the C library's
// locale- and timezone-dependent functions (mktime, strptime).

#include <cstdint>
#include <string>
#include <string_view>

namespace rs::flightlog {

/// Days since 1970-01-01 of a proleptic-Gregorian civil date.
int64_t DaysFromCivil(int64_t y, int64_t m, int64_t d);

/// A civil date and time of day, validated (month 1-12, day within month,
/// hour 0-23, minute 0-59, second 0-60), to nanoseconds since the epoch as if
/// the fields were UTC. Returns false when a field is out of range.
bool CivilToNs(int64_t y, int64_t mo, int64_t d, int64_t h, int64_t mi, int64_t s, int64_t frac_ns, int64_t* t_ns);

/// ISO-8601 / RFC 3339 date-time: "YYYY-MM-DDTHH:MM:SS[.f...][Z|+HH:MM|+HHMM|+HH]"
/// ('T' may be a space; up to 9 fraction digits are kept, more are truncated).
/// The result is UTC when an offset or Z is given; *has_zone says whether one was.
/// The whole (trimmed) string must match.
bool ParseIso8601(std::string_view s, int64_t* t_ns, bool* has_zone);

/// DJI SRT date-time "YYYY-MM-DD HH:MM:SS", also with '.' date separators,
/// unpadded month/day, and a fraction ".fff" or DJI's ",mmm,uuu" groups.
/// Matches a prefix of `s`; *consumed gets its length. Time zone is not
/// recorded by DJI (camera local time), so the result is "as if UTC".
bool ParseDjiDateTime(std::string_view s, size_t* consumed, int64_t* t_ns);

/// Nanoseconds since the epoch -> "YYYY-MM-DDTHH:MM:SS.fffffffff" (no zone
/// suffix: the caller says what clock it is).
std::string FormatIsoNs(int64_t t_ns);

}  // namespace rs::flightlog
