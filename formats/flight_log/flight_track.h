#pragma once
// The normalized flight track every flight-log reader produces (CSV, GPX, PX4
// ULog, ArduPilot DataFlash, DJI SRT, KITTI OXTS). Conventions: docs/conventions.md.

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "formats/altitude_reference.h"

namespace rs {

/// Which clock the track's t_ns values are on.
enum class TimeBase {
  kUtc,   ///< nanoseconds since the Unix epoch, UTC
  kBoot,  ///< nanoseconds since an unknown origin (autopilot boot, video start); no UTC mapping found
};
const char* ToString(TimeBase b);

/// One GNSS position fix.
struct GnssFix {
  int64_t t_ns = 0;  ///< on the track's TimeBase
  double lat_deg = kNaN;
  double lon_deg = kNaN;
  double alt_m = kNaN;
  AltitudeReference alt_ref = AltitudeReference::kUnknown;
  int fix_type = -1;      ///< 0 none, 2 2D, 3 3D, 4 DGPS, 5 RTK float, 6 RTK fixed; -1 unknown
  int satellites = -1;    ///< -1 unknown
  double h_acc_m = kNaN;  ///< horizontal accuracy (1 sigma) where the log gives it
  double v_acc_m = kNaN;  ///< vertical accuracy (1 sigma) where the log gives it
  double ground_speed_m_s = kNaN;
  int64_t source_pos =
      -1;  ///< where the record is in the log: 1-based line (text logs), byte offset (binary); -1 unknown
};

/// Vehicle attitude: rotation from the body frame (FRD) to the local NED frame,
/// as a unit quaternion (w, x, y, z).
struct AttitudeSample {
  int64_t t_ns = 0;
  double qw = 1, qx = 0, qy = 0, qz = 0;
  int64_t source_pos =
      -1;  ///< where the record is in the log: 1-based line (text logs), byte offset (binary); -1 unknown
};

/// A camera trigger/capture event logged by the autopilot.
struct CameraEvent {
  int64_t t_ns = 0;
  int64_t sequence = -1;  ///< image/trigger sequence number, -1 unknown
  double lat_deg = kNaN, lon_deg = kNaN, alt_m = kNaN;
  AltitudeReference alt_ref = AltitudeReference::kUnknown;
  int64_t source_pos =
      -1;  ///< where the record is in the log: 1-based line (text logs), byte offset (binary); -1 unknown
};

/// A whole flight log, normalized. Vectors are sorted by t_ns.
struct FlightTrack {
  std::string source_path;  ///< the file it came from
  std::string format;       ///< "csv", "airdata-csv", "gpx", "px4-ulog", "ardupilot-dataflash", "dji-srt", "kitti-oxts"
  TimeBase time_base = TimeBase::kUtc;
  std::vector<GnssFix> fixes;
  std::vector<AttitudeSample> attitude;
  std::vector<CameraEvent> camera_events;
  std::vector<std::string> notes;  ///< what the reader noticed (dialect, dropped records with reasons, ...)
};

/// Attitude at t_ns: normalized linear interpolation of the two bracketing
/// samples (sign-aligned), exact at a sample; nothing outside the samples.
/// `attitude` must be sorted by t_ns.
std::optional<AttitudeSample> AttitudeAt(const std::vector<AttitudeSample>& attitude, int64_t t_ns);

}  // namespace rs
