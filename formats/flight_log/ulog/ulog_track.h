#pragma once
// Normalizes a PX4 ULog into rs::FlightTrack: GNSS fixes, attitude and camera
// events on a UTC time base where the log allows it. Conventions:
// docs/formats/binary-logs.md.

#include <filesystem>
#include <istream>
#include <string>

#include "formats/flight_log/flight_track.h"
#include "formats/flight_log/ulog/ulog_file.h"

namespace rs {

/// Builds the normalized track from a decoded ULog:
/// - fixes from vehicle_gps_position (else sensor_gps, instance 0; else the
///   estimator's vehicle_global_position), AMSL altitude; records without a
///   fix are dropped and counted in the notes;
/// - attitude from vehicle_attitude (q: body FRD -> NED);
/// - camera events from camera_capture (else camera_trigger).
/// Time base is UTC when GPS time_utc_usec maps boot time to UTC (median
/// offset over all records carrying it), otherwise boot time with a note.
FlightTrack UlogToFlightTrack(const ulog::UlogFile& log, const std::string& path);

/// How a flight log is read: strict about corruption, but a file cut short (power loss) is read
/// up to its last complete message, with a note saying how much was read.
inline constexpr ulog::ReadOptions kFlightLogReadOptions{.recover = false, .read_to_cut = true};

/// Reads and normalizes a ULog from a stream; `path` names it in errors.
FlightTrack ReadUlogTrack(std::istream& in, const std::string& path,
                          const ulog::ReadOptions& options = kFlightLogReadOptions);
/// Reads and normalizes a ULog file.
FlightTrack ReadUlogTrack(const std::filesystem::path& path, const ulog::ReadOptions& options = kFlightLogReadOptions);

}  // namespace rs
