#pragma once
// FlightTrack promises vectors sorted by t_ns; readers call this once at the end.

#include "formats/flight_log/flight_track.h"

namespace rs::flightlog {

/// Stable-sorts fixes, attitude and camera events by t_ns. When any vector
/// was out of order, adds a note saying how many records were and where the
/// first of each kind is (file:line, or file @ byte N for binary logs, from the
/// records' source_pos), so a log with a clock jump is visible, not silently
/// reordered. track->source_path and format must be set.
void SortTrackByTime(FlightTrack* track);

}  // namespace rs::flightlog
