#pragma once
// The frames a stage left out, as `run` and `status` print them under the stage's line.

#include <nlohmann/json.hpp>

namespace rs {

/// Prints "    skipped frame <id>: <reason> (<file>)" per entry of a manifest's
/// `frames.skipped_frames` list ([{frame, reason, where}]), the first `max_lines` of them and a
/// count of the rest.
void PrintSkippedFrames(const nlohmann::json& skipped_frames, size_t max_lines = 20);

}  // namespace rs
