#pragma once
// The frame list the ingest stage writes and every per-frame stage reads
// (frames.csv). Streamed line by line so memory stays flat for long surveys.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

namespace rs {

/// Strong id: a frame's index in the survey (0-based, dense after ingest).
struct FrameId {
  int64_t value = -1;
  auto operator<=>(const FrameId&) const = default;
};

/// One stereo frame as ingest resolved it.
struct FrameRecord {
  FrameId id;
  int64_t t_ns = 0;             ///< capture time on the survey time base (UTC when a log aligned it)
  std::filesystem::path left;   ///< absolute path of the left (reference) image
  std::filesystem::path right;  ///< absolute path of the right (target) image
};

void WriteFrameIndex(std::ostream& out, const std::vector<FrameRecord>& frames);
void WriteFrameIndex(const std::filesystem::path& path, const std::vector<FrameRecord>& frames);
/// Throws InputError with the line on malformed rows.
std::vector<FrameRecord> ReadFrameIndex(std::istream& in, const std::string& path_for_errors);
std::vector<FrameRecord> ReadFrameIndex(const std::filesystem::path& path);

}  // namespace rs
