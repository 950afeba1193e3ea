#pragma once
// Puts frames and the flight log on one time base and interpolates each
// frame's GNSS/attitude prior. Convention: clock_offset = camera clock - log
// clock, so t_log = t_camera - offset.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "formats/flight_log/flight_track.h"
#include "formats/frame_index.h"
#include "formats/frame_priors.h"

namespace rs {

/// An automatic clock-offset estimate and how much to trust it.
struct ClockOffsetEstimate {
  int64_t offset_ns = 0;   ///< camera - log
  int64_t spread_ns = 0;   ///< median absolute deviation of the per-pair offsets
  int matched_pairs = 0;   ///< frames paired with camera events
  int index_shift = 0;     ///< event index - frame index of the best pairing
  bool confident = false;  ///< spread below the limit and enough pairs
  std::string method;      ///< "camera-events"
};

/// Pairs frames with the log's camera trigger events in order, trying every
/// index shift. Shifts whose per-pair offsets agree (MAD <= confident_spread)
/// are candidates; the one pairing the most frames wins. Periodic triggers make
/// shifts that differ by whole frame periods equally consistent: such ties are
/// broken by closeness to `prior_offset_ns` (the configured offset), and the
/// estimate is confident only when the prior separates them clearly.
/// Needs at least `min_pairs` events; nullopt otherwise.
std::optional<ClockOffsetEstimate> EstimateClockOffsetFromEvents(const std::vector<int64_t>& frame_t_ns,
                                                                 const std::vector<CameraEvent>& events,
                                                                 int64_t prior_offset_ns = 0, int min_pairs = 5,
                                                                 int64_t confident_spread_ns = 5'000'000);

/// Interpolates priors for frames: position linearly, attitude by slerp.
/// Frames outside the fixes' span or inside a gap longer than max_gap_ns get
/// that status and no values.
std::vector<FramePrior> InterpolatePriors(const std::vector<FrameRecord>& frames, const FlightTrack& track,
                                          int64_t clock_offset_ns, int64_t max_gap_ns);

/// Plausibility findings about a track (gaps, jumps, missing fixes), one line each.
struct TrackFindings {
  int gaps = 0;                       ///< consecutive fixes further apart than max_gap
  int jumps = 0;                      ///< consecutive fixes implying speed above max_speed
  int no_fix = 0;                     ///< fixes flagged as no fix (fix_type 0 or 1)
  std::vector<std::string> messages;  ///< first few of each, with times
};
TrackFindings CheckTrack(const FlightTrack& track, int64_t max_gap_ns, double max_speed_m_s);

}  // namespace rs
