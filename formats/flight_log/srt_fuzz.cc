// libFuzzer target: the DJI SRT reader must answer any bytes with a track or an rs::InputError.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "formats/flight_log/dji_srt.h"
#include "formats/input_error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
    rs::ReadDjiSrt(in, "fuzz.srt");
  } catch (const rs::InputError&) {}
  return 0;
}
