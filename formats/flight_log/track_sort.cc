#include "formats/flight_log/track_sort.h"

#include <algorithm>
#include <string>

namespace rs::flightlog {
namespace {

template <typename T>
int64_t SortOne(std::vector<T>* v) {
  int64_t out_of_order = 0;
  for (size_t i = 1; i < v->size(); ++i) out_of_order += (*v)[i].t_ns < (*v)[i - 1].t_ns;
  if (out_of_order > 0) std::stable_sort(v->begin(), v->end(), [](const T& a, const T& b) { return a.t_ns < b.t_ns; });
  return out_of_order;
}

}  // namespace

void SortTrackByTime(FlightTrack* track) {
  const int64_t nf = SortOne(&track->fixes);
  const int64_t na = SortOne(&track->attitude);
  const int64_t nc = SortOne(&track->camera_events);
  if (nf + na + nc > 0)
    track->notes.push_back("records were not in time order and were sorted (" + std::to_string(nf) + " fixes, " +
                           std::to_string(na) + " attitude, " + std::to_string(nc) +
                           " camera events went back in time)");
}

}  // namespace rs::flightlog
