#pragma once
// Writes an rs::FlightTrack as an ArduPilot DataFlash log (.bin) that
// ArduPilot tools (MAVExplorer, pymavlink) and rs::ReadDataflashTrack read:
// self-describing FMT records, then GPS, ATT and CAM messages named and
// scaled like ArduPilot's. Layout and units: docs/formats/binary-logs.md ("Writing").

#include <cstdint>
#include <filesystem>
#include <ostream>

#include "formats/flight_log/flight_track.h"

namespace rs {

namespace dataflash {

/// GPS week and milliseconds of week.
struct GpsWeekMs {
  int64_t week = 0;
  int64_t ms = 0;
};

/// Unix UTC nanoseconds to GPS week / ms of week (rounded to the nearest ms),
/// with the GPS-UTC leap seconds of gps_time.h (18 s since 2017). Inverse of
/// GpsWeekMsToUtcNs outside the leap second itself.
GpsWeekMs UtcNsToGpsWeekMs(int64_t utc_ns);

}  // namespace dataflash

/// How to write a DataFlash log.
struct DataflashWriteOptions {
  /// Geoid height N = ellipsoidal height - AMSL height (m). DataFlash stores
  /// AMSL altitudes; NaN: N unknown, the track's altitudes must then be AMSL.
  double geoid_height_m = kNaN;
  /// Boot time (µs) of the track's first sample (TimeUS). Boot time 0 is never
  /// used by ArduPilot for a GPS record with time, and our reader ignores it
  /// when mapping boot time to UTC. Used only for UTC tracks.
  int64_t first_sample_boot_us = 1'000'000;
};

/// Writes `track` as a DataFlash log: FMT (itself first), then in boot-time order
/// - GPS per fix: TimeUS, I = 0, Status (fix type), GMS/GWk (GPS ms of week and
///   week; 0/0 for boot-time tracks, as a receiver without time), NSats, Lat/Lng
///   (int32 1e-7 deg), Alt (int32 cm, AMSL), Spd (m/s); Status and NSats only
///   when every fix has them;
/// - ATT per sample: TimeUS, Roll, Pitch (int16 centidegrees), Yaw (uint16
///   centidegrees, 0..360): ZYX Euler angles of body FRD in NED;
/// - CAM per event: TimeUS, I = 0, Img (when every event has a sequence),
///   GPSTime/GPSWeek, Lat/Lng (when every event has them), Alt and GPSAlt
///   (int32 cm AMSL), R/P/Y (centidegrees; attitude interpolated at the event,
///   only when every event lies within the attitude samples).
/// Throws std::invalid_argument for a track it cannot represent (non-finite or
/// out-of-range fix coordinates, altitudes that are not AMSL without a geoid
/// height, negative times on a boot-time track).
void WriteDataflashTrack(std::ostream& out, const FlightTrack& track, const DataflashWriteOptions& options = {});
/// Writes the log to a file; throws std::runtime_error when it cannot be written.
void WriteDataflashTrack(const std::filesystem::path& path, const FlightTrack& track,
                         const DataflashWriteOptions& options = {});

}  // namespace rs
