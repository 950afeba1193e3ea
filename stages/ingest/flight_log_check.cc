#include "stages/ingest/flight_log_check.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stages/ingest/time_alignment.h"

namespace rs {
namespace {

int64_t Nanoseconds(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }

// Fraction of frames whose log time (camera time - offset) lies inside the fixes' span.
double InSpanFraction(const std::vector<int64_t>& frame_t_ns, const FlightTrack& track, int64_t offset_ns) {
  if (frame_t_ns.empty() || track.fixes.empty()) return 0.0;
  const int64_t first = track.fixes.front().t_ns, last = track.fixes.back().t_ns;
  const auto inside = std::count_if(frame_t_ns.begin(), frame_t_ns.end(), [&](int64_t t) {
    const int64_t t_log = t - offset_ns;
    return t_log >= first && t_log <= last;
  });
  return static_cast<double>(inside) / static_cast<double>(frame_t_ns.size());
}

// "the frames (log clock 1699999000.000 to 1699999003.500 s) and the log (1699999999.000 to ...)".
std::string Ranges(const std::vector<int64_t>& frame_t_ns, const FlightTrack& track, int64_t offset_ns) {
  const auto [lo, hi] = std::minmax_element(frame_t_ns.begin(), frame_t_ns.end());
  return fmt::format("{} frames at log time {:.3f} to {:.3f} s, log from {:.3f} to {:.3f} s", frame_t_ns.size(),
                     (*lo - offset_ns) * 1e-9, (*hi - offset_ns) * 1e-9, track.fixes.front().t_ns * 1e-9,
                     track.fixes.back().t_ns * 1e-9);
}

}  // namespace

std::optional<FlightLogAlignment> CheckFlightLog(const FlightTrack& track, const std::filesystem::path& log_path,
                                                 const nlohmann::json& log_spec, const std::vector<int64_t>& frame_t_ns,
                                                 const IngestOptions& o, ProblemList& problems) {
  const InputLocation where = InputLocation::File(log_path.string());
  for (const auto& n : track.notes) problems.Warning(where, n);
  if (track.fixes.empty()) {
    problems.Error(where, "flight log has no GNSS fix");
    return std::nullopt;
  }
  const TrackFindings findings = CheckTrack(track, Nanoseconds(o.max_log_gap_s), o.max_speed_m_s);
  for (const auto& m : findings.messages) problems.Warning(where, m);
  if (frame_t_ns.empty()) return FlightLogAlignment{Nanoseconds(log_spec.value("clock_offset_s", 0.0)), {}};

  const bool configured = log_spec.contains("clock_offset_s");
  const int64_t configured_ns = Nanoseconds(log_spec.value("clock_offset_s", 0.0));
  FlightLogAlignment out{
      configured_ns,
      {{"configured_s", configured_ns * 1e-9}, {"used_s", configured_ns * 1e-9}, {"method", "configured"}}};
  std::optional<ClockOffsetEstimate> estimate;
  if (o.estimate_clock_offset) {
    estimate = EstimateClockOffsetFromEvents(frame_t_ns, track.camera_events, configured_ns);
    if (estimate)
      out.report["estimate"] = {{"offset_s", estimate->offset_ns * 1e-9},   {"spread_s", estimate->spread_ns * 1e-9},
                                {"matched_pairs", estimate->matched_pairs}, {"index_shift", estimate->index_shift},
                                {"confident", estimate->confident},         {"method", estimate->method}};
    else
      out.report["estimate"] = "not possible: the log has too few camera events";
  }
  const std::string hint =
      estimate && estimate->confident
          ? fmt::format("; the log's camera events suggest clock_offset_s = {:.3f}", estimate->offset_ns * 1e-9)
          : "";
  // A configured offset is the user's statement: it must hold on its own, never be silently replaced.
  if (configured && InSpanFraction(frame_t_ns, track, configured_ns) < o.min_in_span_fraction) {
    problems.Error(where, fmt::format("inputs.flight_log.clock_offset_s = {} s puts the frames outside this log "
                                      "(fewer than {:.0f}% inside, ingest.min_in_span_fraction): {}{}",
                                      log_spec["clock_offset_s"].dump(), 100 * o.min_in_span_fraction,
                                      Ranges(frame_t_ns, track, configured_ns), hint));
    return std::nullopt;
  }
  if (estimate && estimate->confident) {
    if (configured && estimate->offset_ns != configured_ns)
      problems.Warning(where,
                       fmt::format("clock offset: using the camera-event estimate {:.3f} s (spread {:.3f} s) "
                                   "instead of the configured inputs.flight_log.clock_offset_s = {:.3f} s",
                                   estimate->offset_ns * 1e-9, estimate->spread_ns * 1e-9, configured_ns * 1e-9));
    out.offset_ns = estimate->offset_ns;
    out.report["used_s"] = out.offset_ns * 1e-9;
    out.report["method"] = estimate->method;
  } else if (estimate) {
    problems.Warning(where, fmt::format("clock offset estimate {:.3f} s is not confident (spread {:.3f} s): using "
                                        "the {} {:.3f} s",
                                        estimate->offset_ns * 1e-9, estimate->spread_ns * 1e-9,
                                        configured ? "configured" : "default", configured_ns * 1e-9));
  }
  const double in_span = InSpanFraction(frame_t_ns, track, out.offset_ns);
  if (in_span < o.min_in_span_fraction) {
    problems.Error(where,
                   fmt::format("only {:.0f}% of frames fall inside the log's time span "
                               "(ingest.min_in_span_fraction = {}): {}: wrong log, or set the clock offset "
                               "(inputs.flight_log.clock_offset_s){}",
                               100 * in_span, o.min_in_span_fraction, Ranges(frame_t_ns, track, out.offset_ns), hint));
    return std::nullopt;
  }
  return out;
}

}  // namespace rs
