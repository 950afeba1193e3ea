#pragma once
// The flight-log checks `validate` and `run` share: what the reader noticed, track findings, and
// whether the log covers the frames with the clock offset the run will use. One function, so a
// log that fails one command fails the other with the same message.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "formats/flight_log/flight_track.h"
#include "formats/input_error.h"
#include "stages/ingest/ingest_stage.h"

namespace rs {

/// The clock offset a run uses (camera - log) and how it was chosen (ingest.json "clock_offset").
struct FlightLogAlignment {
  int64_t offset_ns = 0;
  nlohmann::json report;
};

/// Checks `track` (read from `log_path`, configured by `log_spec` = inputs.flight_log) against the
/// camera times of every listed frame. Reader notes and track findings are warnings. Errors: no
/// GNSS fix; fewer than options.min_in_span_fraction of the frames inside the log's span. The
/// offset: a configured clock_offset_s must itself put the frames inside the log (an error names
/// the option, the log and both time ranges otherwise); a confident camera-event estimate then
/// refines it, with a warning stating both values. Without a configured offset the confident
/// estimate, else 0, is used. Returns nullopt when an error was added.
std::optional<FlightLogAlignment> CheckFlightLog(const FlightTrack& track, const std::filesystem::path& log_path,
                                                 const nlohmann::json& log_spec, const std::vector<int64_t>& frame_t_ns,
                                                 const IngestOptions& options, ProblemList& problems);

}  // namespace rs
