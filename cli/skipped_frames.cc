#include "cli/skipped_frames.h"

#include <fmt/format.h>

namespace rs {

void PrintSkippedFrames(const nlohmann::json& skipped_frames, size_t max_lines) {
  size_t printed = 0;
  for (const auto& s : skipped_frames) {
    if (printed == max_lines) {
      fmt::print("    ... and {} more skipped frame(s): see manifest.json\n", skipped_frames.size() - printed);
      return;
    }
    const std::string where = s.value("where", std::string());
    fmt::print("    skipped frame {}: {}{}\n", s.value("frame", int64_t{-1}), s.value("reason", std::string("?")),
               where.empty() ? "" : " (" + where + ")");
    ++printed;
  }
}

}  // namespace rs
