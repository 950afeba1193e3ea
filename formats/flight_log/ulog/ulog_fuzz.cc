// libFuzzer target: the ULog reader (strict and recovering) and the track
// conversion must never crash, hang or allocate without bound on any input.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "formats/flight_log/ulog/ulog_track.h"
#include "formats/input_error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  for (bool recover : {false, true}) {
    std::istringstream in(bytes);
    try {
      const rs::FlightTrack t = rs::ReadUlogTrack(in, "fuzz.ulg", rs::ulog::ReadOptions{recover});
      (void)t;
    } catch (const rs::InputError&) {}
  }
  return 0;
}
