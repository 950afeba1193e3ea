#pragma once
// DJI .SRT subtitle telemetry (the per-frame position/exposure subtitles DJI
// drones write beside each video). Dialects, time and altitude conventions and
// the GPS(...) (lon, lat) order rule: docs/formats/text-logs.md.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/flight_log/flight_track.h"

namespace rs {

/// Reads a DJI SRT file (any of the known firmware dialects: `[latitude: ..]
/// [longitude: ..]` tags, `[rel_alt: .. abs_alt: ..]`, `GPS(lon, lat, n)` with
/// `BAROMETER:`/`Hb:`/`H ..m`, Matrice `GPS(lat, lon, altM)`, `HOME(...)`,
/// `F.PRY (pitch, roll, yaw)`). One GnssFix per subtitle record (plus an
/// AttitudeSample where F.PRY is given). Time base is kBoot: t_ns is the
/// subtitle start time on the video clock (or, for dialects without subtitle
/// timecodes, the record date-time minus the first one), because DJI writes
/// camera local time without a time zone; the first local date-time goes into
/// the notes. Records whose GPS reads N/A are dropped and counted in the notes.
/// Throws rs::InputError (file:line[:column]) on truncated or malformed records.
FlightTrack ReadDjiSrt(std::istream& in, const std::string& path);

/// Opens `path` and reads it as DJI SRT.
FlightTrack ReadDjiSrt(const std::filesystem::path& path);

}  // namespace rs
