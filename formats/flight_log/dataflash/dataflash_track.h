#pragma once
// Normalizes an ArduPilot DataFlash log into rs::FlightTrack: primary GPS
// fixes, attitude (ATT, else AHR2) and camera events (CAM, else TRIG), on UTC
// from the GPS week/ms where the log has them. Conventions:
// docs/formats/binary-logs.md.

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <istream>
#include <string>

#include "formats/flight_log/dataflash/dataflash_file.h"
#include "formats/flight_log/flight_track.h"

namespace rs {
namespace dataflash {

/// Mapping of the autopilot's boot clock to UTC:
/// UTC = utc0 + offset + rate * (boot - boot0), all in nanoseconds.
struct BootClockFit {
  int64_t boot0 = 0, utc0 = 0;
  double offset_ns = 0;
  double rate = 1;            ///< UTC seconds per boot-clock second
  double max_residual_s = 0;  ///< largest |fit - GPS time| over the fitted records
  int pairs = 0;              ///< GPS records used
  /// UTC nanoseconds of a boot-clock time.
  int64_t ToUtcNs(int64_t boot_ns) const {
    const double d = offset_ns + rate * static_cast<double>(boot_ns - boot0);
    return utc0 + static_cast<int64_t>(std::llround(std::clamp(d, -2e18, 2e18)));  // inputs are range-checked
  }
};

/// Least-squares fit of boot time against GPS week/ms over the primary GPS's
/// 3D fixes (first record of each GPS time; one pass of outlier rejection for
/// residuals over 1 s). Some boards' boot clock runs measurably off rate (the
/// 2014 PXF logs: ~8 %), so a constant offset is not enough. nullopt when the
/// log has no usable GPS time.
std::optional<BootClockFit> FitBootClock(const DataflashFile& log);

}  // namespace dataflash

/// Builds the normalized track from a decoded DataFlash log:
/// - fixes from GPS (instance 0 where the message has an instance column;
///   GPS2 is ignored), AMSL altitude, Status as fix type; records with
///   Status < 2 (no fix) are dropped and counted in the notes;
/// - attitude from ATT (else AHR2): Roll/Pitch/Yaw (deg) -> body FRD -> NED quaternion;
/// - camera events from CAM (else TRIG).
/// Time base is UTC when FitBootClock succeeds (fixes then carry their own GPS
/// time; records repeating the previous GPS time are dropped and counted),
/// otherwise boot time with a note. Skipped bytes are
/// reported in the notes.
FlightTrack DataflashToFlightTrack(const dataflash::DataflashFile& log, const std::string& path);

/// Reads and normalizes a DataFlash log from a stream; `path` names it in errors.
FlightTrack ReadDataflashTrack(std::istream& in, const std::string& path);
/// Reads and normalizes a DataFlash log file.
FlightTrack ReadDataflashTrack(const std::filesystem::path& path);

}  // namespace rs
