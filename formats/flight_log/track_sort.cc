#include "formats/flight_log/track_sort.h"

#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <string>

#include "formats/input_error.h"

namespace rs::flightlog {
namespace {

// The first record whose time is earlier than the one before it, as a located sentence.
struct Backwards {
  int64_t count = 0;                 ///< records earlier than their predecessor
  std::optional<std::string> first;  ///< "fix at log.csv:73 is 0.500 s earlier than the one before (line 64)"
};

std::string Where(const FlightTrack& track, int64_t pos) {
  if (pos < 0) return track.source_path;
  const bool binary = track.format == "px4-ulog" || track.format == "ardupilot-dataflash";
  return (binary ? InputLocation::Byte(track.source_path, pos) : InputLocation::Line(track.source_path, pos))
      .ToString();
}

template <typename T>
Backwards SortOne(const FlightTrack& track, const char* kind, std::vector<T>* v) {
  Backwards out;
  for (size_t i = 1; i < v->size(); ++i) {
    const T &prev = (*v)[i - 1], &cur = (*v)[i];
    if (cur.t_ns >= prev.t_ns) continue;
    if (++out.count == 1)
      out.first =
          fmt::format("{} at {} is {:.3f} s earlier than the one before it (at {})", kind, Where(track, cur.source_pos),
                      (prev.t_ns - cur.t_ns) * 1e-9, Where(track, prev.source_pos));
  }
  if (out.count > 0) std::stable_sort(v->begin(), v->end(), [](const T& a, const T& b) { return a.t_ns < b.t_ns; });
  return out;
}

}  // namespace

void SortTrackByTime(FlightTrack* track) {
  const Backwards nf = SortOne(*track, "fix", &track->fixes);
  const Backwards na = SortOne(*track, "attitude sample", &track->attitude);
  const Backwards nc = SortOne(*track, "camera event", &track->camera_events);
  if (nf.count + na.count + nc.count == 0) return;
  std::string first;
  for (const Backwards* b : {&nf, &na, &nc})
    if (b->first) first += "; " + *b->first;
  track->notes.push_back(
      fmt::format("time goes backwards ({} fixes, {} attitude, {} camera events earlier than "
                  "the record before them; sorted by time){}",
                  nf.count, na.count, nc.count, first));
}

}  // namespace rs::flightlog
