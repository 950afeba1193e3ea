// libFuzzer target: the DataFlash reader and track conversion must never
// crash, hang or allocate without bound on any input.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "formats/flight_log/dataflash/dataflash_track.h"
#include "formats/input_error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const rs::FlightTrack t = rs::ReadDataflashTrack(in, "fuzz.bin");
    (void)t;
  } catch (const rs::InputError&) {}
  return 0;
}
