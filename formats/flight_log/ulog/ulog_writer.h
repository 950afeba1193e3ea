#pragma once
// Writes an rs::FlightTrack as a PX4 ULog (.ulg, version 1) that PX4 tools
// (pyulog, PlotJuggler, Flight Review) and rs::ReadUlogTrack read: topics
// vehicle_gps_position, vehicle_attitude and camera_capture, laid out like
// PX4's own messages. Layout and units: docs/formats/binary-logs.md ("Writing").

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>

#include "formats/flight_log/flight_track.h"

namespace rs {

/// How to write a ULog.
struct UlogWriteOptions {
  /// Value of the `sys_name` info message.
  std::string sys_name = "roadsurvey";
  /// Geoid height N = ellipsoidal height - AMSL height (m). ULog stores AMSL
  /// altitudes (`alt`) and, where N is known, ellipsoidal ones (`alt_ellipsoid`).
  /// NaN: N unknown; the track's altitudes must then be AMSL and
  /// `alt_ellipsoid` is left out of the format.
  double geoid_height_m = kNaN;
  /// Boot time (µs) given to the track's first sample. Boot time 0 means
  /// "not set" to PX4 tools (and to our reader's boot->UTC mapping), so a real
  /// log never starts there. Used only for UTC tracks; boot-time tracks keep
  /// their own clock.
  int64_t first_sample_boot_us = 1'000'000;
};

/// Writes `track` as ULog v1: header, flag bits, format definitions, info
/// (sys_name, roadsurvey_source), subscriptions and data records in time order.
/// - vehicle_gps_position per fix: timestamp, time_utc_usec (UTC tracks; 0
///   for boot-time tracks), lat/lon int32 1e-7 deg, alt int32 mm AMSL,
///   alt_ellipsoid int32 mm (when N is known), eph/epv/vel_m_s float,
///   fix_type and satellites_used uint8 (each present only when every fix has it);
/// - vehicle_attitude per sample: timestamp, q[4] float (body FRD -> NED);
/// - camera_capture per event: timestamp, timestamp_utc, seq (when every event
///   has one), lat/lon double deg, alt float AMSL, q[4] (attitude interpolated
///   at the event; NaN outside the attitude samples), result = 1.
/// Timestamps are rounded to µs. Throws std::invalid_argument for a track it
/// cannot represent: non-finite or out-of-range fix coordinates, altitudes that
/// are not AMSL without a geoid height, or (boot-time tracks) negative times.
void WriteUlogTrack(std::ostream& out, const FlightTrack& track, const UlogWriteOptions& options = {});
/// Writes the ULog to a file; throws std::runtime_error when it cannot be written.
void WriteUlogTrack(const std::filesystem::path& path, const FlightTrack& track, const UlogWriteOptions& options = {});

}  // namespace rs
