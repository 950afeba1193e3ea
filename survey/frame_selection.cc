#include "survey/frame_selection.h"

#include <fmt/format.h>

#include <charconv>

#include "formats/input_error.h"
#include "survey/options.h"

namespace rs {
namespace {

int64_t ParseBound(const std::string& text, const std::string& whole) {
  int64_t v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || ptr != text.data() + text.size() || v < 0)
    throw OptionError(fmt::format("--frames {}: '{}' is not a non-negative frame index (expected A:B)", whole, text));
  return v;
}

}  // namespace

std::string FrameSelection::ToString() const {
  if (All()) return "all";
  return end == std::numeric_limits<int64_t>::max() ? fmt::format("{}:", begin) : fmt::format("{}:{}", begin, end);
}

std::string FrameSelection::FolderName() const {
  if (All()) return "";
  return end == std::numeric_limits<int64_t>::max() ? fmt::format("frames-{}-end", begin)
                                                    : fmt::format("frames-{}-{}", begin, end);
}

void FrameSelection::RequireSelects(int64_t frame_count, const std::string& survey_file) const {
  if (All() || (begin < frame_count && end > 0)) return;
  const std::string range =
      frame_count > 0 ? fmt::format("{} frames, ids 0 to {} (--frames 0:{})", frame_count, frame_count - 1, frame_count)
                      : std::string("no frames");
  throw InputError(InputLocation::File(survey_file),
                   fmt::format("--frames {} selects no frame: the survey has {}", ToString(), range));
}

FrameSelection FrameSelection::Parse(const std::string& text) {
  FrameSelection s;
  if (text == "all" || text.empty()) return s;
  const auto colon = text.find(':');
  if (colon == std::string::npos) throw OptionError(fmt::format("--frames {}: expected A:B, A: or :B", text));
  const std::string a = text.substr(0, colon), b = text.substr(colon + 1);
  if (!a.empty()) s.begin = ParseBound(a, text);
  if (!b.empty()) s.end = ParseBound(b, text);
  if (s.end <= s.begin) throw OptionError(fmt::format("--frames {} violates A < B", text));
  return s;
}

}  // namespace rs
