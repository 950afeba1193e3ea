// libFuzzer target: both CSV readers (roadsurvey track CSV, generic/AirData CSV)
// and the KITTI OXTS record parser must answer any bytes with a track or an
// rs::InputError.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "formats/flight_log/flight_csv.h"
#include "formats/flight_log/kitti_oxts.h"
#include "formats/flight_log/track_csv.h"
#include "formats/input_error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    std::istringstream in(text);
    rs::ReadTrackCsv(in, "fuzz.csv");
  } catch (const rs::InputError&) {}
  try {
    std::istringstream in(text);
    rs::ReadFlightCsv(in, "fuzz.csv");
  } catch (const rs::InputError&) {}
  try {
    std::istringstream in(text);
    rs::FlightTrack t;
    rs::ReadKittiOxtsRecord(in, "fuzz.txt", 0, &t);
  } catch (const rs::InputError&) {}
  return 0;
}
