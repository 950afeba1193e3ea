#pragma once
// roadsurvey's own flight-track CSV (written by the simulator and by
// `roadsurvey` itself; format in docs/formats/text-logs.md):
//
//   # roadsurvey flight track v1, time_base=utc
//   # note: <free text, one FlightTrack note per line>          (optional)
//   t_ns,type,lat_deg,lon_deg,alt_m,alt_ref,fix_type,satellites,h_acc_m,v_acc_m,qw,qx,qy,qz,sequence
//   1700000000000000000,gnss,46.1,14.5,312.5,amsl,3,12,0.8,1.5,,,,,
//   1700000000010000000,attitude,,,,,,,,,0.7071067811865476,0,0,0.7071067811865476,
//   1700000000020000000,camera,46.1,14.5,312.5,amsl,,,,,,,,,17
//
// An optional extra column `ground_speed_m_s` (gnss rows) is written only when
// some fix carries a ground speed.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/flight_log/flight_track.h"

namespace rs {

/// Writes `track` as roadsurvey track CSV. Doubles use the shortest text that
/// parses back bit-exactly, so Write -> Read is lossless (except `format` and
/// `source_path`, which the reader sets).
void WriteTrackCsv(std::ostream& out, const FlightTrack& track);

/// Reads roadsurvey track CSV. `path` is only used in error locations and
/// FlightTrack::source_path. Throws rs::InputError (file:line:column) on an
/// unknown/missing/duplicate column, a missing required field, a field that is
/// set but unused by its row type, or an out-of-range value.
FlightTrack ReadTrackCsv(std::istream& in, const std::string& path);

/// Opens `path` and reads it as roadsurvey track CSV.
FlightTrack ReadTrackCsv(const std::filesystem::path& path);

}  // namespace rs
