// libFuzzer target: every COLMAP reader must either parse or throw InputError, never crash, hang or
// allocate beyond the input's size.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "formats/colmap/colmap_io.h"
#include "formats/input_error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  auto attempt = [&](auto read) {
    try {
      read();
    } catch (const rs::InputError&) {}
  };
  auto text = [&](auto read) {
    attempt([&] {
      std::istringstream in(bytes);
      read(in, "fuzz.txt");
    });
  };
  text(rs::ReadColmapCamerasText);
  text(rs::ReadColmapImagesText);
  text(rs::ReadColmapPointsText);
  text(rs::ReadColmapRigConfig);
  attempt([&] { rs::ReadColmapCamerasBinary(bytes, "fuzz.bin"); });
  attempt([&] { rs::ReadColmapImagesBinary(bytes, "fuzz.bin"); });
  attempt([&] { rs::ReadColmapPointsBinary(bytes, "fuzz.bin"); });
  return 0;
}
