// libFuzzer target: every trajectory reader must either parse or throw InputError, never crash or hang.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "formats/input_error.h"
#include "formats/trajectory/euroc_trajectory.h"
#include "formats/trajectory/kitti_poses.h"
#include "formats/trajectory/timestamp_text.h"
#include "formats/trajectory/tum_trajectory.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  (void)rs::ParseSecondsToNs(text);
  auto attempt = [&](auto read) {
    std::istringstream in(text);
    try {
      read(in);
    } catch (const rs::InputError&) {}
  };
  attempt([](std::istream& in) { rs::ReadTumTrajectory(in, "fuzz.tum"); });
  attempt([](std::istream& in) { rs::ReadEurocTrajectory(in, "fuzz.csv"); });
  attempt([](std::istream& in) { rs::ReadKittiPoses(in, "fuzz.txt"); });
  attempt([](std::istream& in) { rs::ReadKittiTimes(in, "times.txt"); });
  return 0;
}
