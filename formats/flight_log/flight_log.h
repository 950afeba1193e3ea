#pragma once
// Any supported flight log, by name or detected from its content, read into
// the normalized FlightTrack. Formats: docs/formats.md.

#include <filesystem>
#include <string>

#include "formats/flight_log/flight_track.h"

namespace rs {

/// The format a log is in, from its first bytes (magic numbers, XML root,
/// CSV header) and, for KITTI OXTS, the folder layout. Throws InputError
/// naming the file when nothing matches.
std::string DetectFlightLogFormat(const std::filesystem::path& path);

/// Reads `path` in `format` ("auto" detects it): one of csv, airdata-csv,
/// gpx, px4-ulog, ardupilot-dataflash, dji-srt, kitti-oxts.
FlightTrack ReadFlightLog(const std::filesystem::path& path, const std::string& format = "auto");

}  // namespace rs
