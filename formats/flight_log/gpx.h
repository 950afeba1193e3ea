#pragma once
// GPX 1.0 / 1.1 (the GPS exchange format most flight apps and loggers export).
// Conventions: docs/formats/text-logs.md.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/flight_log/flight_track.h"

namespace rs {

/// Reads a GPX file. Fixes come from all trk/trkseg/trkpt points; when the file
/// has none, from rte/rtept, else from wpt (notes say which). <ele> is taken as
/// height above mean sea level (the spec says WGS84 ellipsoid, but receivers
/// and apps write MSL). <time> (ISO-8601, fractional seconds, zone offsets;
/// no zone = UTC per the spec) gives TimeBase::kUtc. Points without <time>
/// among timed ones are dropped and counted; when no point has a time the
/// points are kept in file order with TimeBase::kBoot and t_ns = the point's
/// index (0, 1, 2, ...), and a note says the track has no time.
/// Throws rs::InputError (file:line:column) on malformed XML, a non-GPX root,
/// a bad or missing lat/lon, a bad <time>/<ele>, or a file without points.
FlightTrack ReadGpx(std::istream& in, const std::string& path);

/// Opens `path` and reads it as GPX.
FlightTrack ReadGpx(const std::filesystem::path& path);

}  // namespace rs
