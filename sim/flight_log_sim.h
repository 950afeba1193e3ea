#pragma once
// The simulated flight log: GNSS fixes with white noise and a slowly varying
// bias, attitude with noise, and camera trigger events, on the log clock (UTC).
// The camera clock (timestamps.csv) runs clock_offset_s ahead of it.

#include <cstdint>
#include <iosfwd>
#include <vector>

#include <GeographicLib/LocalCartesian.hpp>

#include "formats/flight_log/flight_track.h"
#include "sim/flight_path.h"
#include "sim/simulation_options.h"

namespace rs::sim {

/// Geoid height N (ellipsoidal - AMSL, m) of the simulated world. The world has
/// no geoid model, so AMSL heights equal ellipsoidal ones; the autopilot logs
/// (flight_log.ulg / .bin, which store AMSL) therefore carry the same heights
/// as flight_log.csv (ellipsoidal).
inline constexpr double kSimGeoidHeightM = 0.0;

/// True time (log clock, UTC ns) of frame k.
int64_t FrameTimeNs(const SimulationOptions& o, int k);
/// Camera-clock time of frame k: FrameTimeNs + clock_offset_s.
int64_t CameraTimeNs(const SimulationOptions& o, int k);

/// Flight log covering the frames plus 1 s before and after.
FlightTrack SimulateFlightLog(const SimulationOptions& o, const FlightPath& path,
                              const GeographicLib::LocalCartesian& enu);

/// Writes the GNSS fixes as a GPX 1.1 track (ele = ellipsoidal height, time UTC with ms).
void WriteGpx(std::ostream& out, const FlightTrack& track, const std::string& name);

/// "2023-11-14T22:13:20.125Z"
std::string IsoTimeUtc(int64_t t_ns);

}  // namespace rs::sim
