#pragma once
// Third-party flight-log CSV: any CSV with a header of common column names
// (time/timestamp/datetime, lat/latitude, lon/lng/longitude, alt/altitude/...),
// and the AirData export of DJI flight logs (units in the column names:
// `time(millisecond)`, `datetime(utc)`, `height_above_takeoff(feet)`,
// `altitude_above_seaLevel(feet)`, `speed(mph)`, ...). Column table, unit and
// altitude rules: docs/formats/text-logs.md.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/flight_log/flight_track.h"

namespace rs {

/// Reads a generic or AirData flight-log CSV (format "csv" or "airdata-csv").
/// Units named in a column ("(feet)", "(mph)", "(millisecond)", ...) are
/// converted to SI; the altitude column is chosen by preference AMSL >
/// ellipsoid > unspecified > take-off-relative and its reference and name go
/// into the notes. Rows without a position (empty or 0,0) are dropped and
/// counted. Unknown columns are ignored and listed in the notes.
/// Throws rs::InputError (file:line[:column]) when the header lacks a
/// latitude/longitude column, a row has the wrong field count, or a value is
/// malformed or out of range.
FlightTrack ReadFlightCsv(std::istream& in, const std::string& path);

/// Opens `path` and reads it as a generic/AirData flight-log CSV.
FlightTrack ReadFlightCsv(const std::filesystem::path& path);

}  // namespace rs
