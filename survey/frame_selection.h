#pragma once
// --frames A:B : which frames of the survey a run covers, by frame id (Python-style, B exclusive).

#include <cstdint>
#include <limits>
#include <string>

namespace rs {

/// A half-open range of frame indices [begin, end). Default: all frames.
struct FrameSelection {
  int64_t begin = 0;
  int64_t end = std::numeric_limits<int64_t>::max();

  bool All() const { return begin == 0 && end == std::numeric_limits<int64_t>::max(); }
  bool Contains(int64_t index) const { return index >= begin && index < end; }
  /// "all" or "A:B" (canonical, used in cache markers).
  std::string ToString() const;
  /// Parses "A:B", "A:", ":B" or "all"; throws OptionError naming the rule broken.
  static FrameSelection Parse(const std::string& text);
};

}  // namespace rs
