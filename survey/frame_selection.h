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
  /// Folder of a run over this selection below the output folder: "frames-A-B" ("frames-A-end"
  /// for "A:"); "" for all frames (a full run publishes at the top of the output folder).
  std::string FolderName() const;
  /// Throws InputError at `survey_file` when none of the survey's frames (ids 0 to
  /// frame_count - 1) is selected; the message states the survey's frame range.
  void RequireSelects(int64_t frame_count, const std::string& survey_file) const;
  /// Parses "A:B", "A:", ":B" or "all"; throws OptionError naming the rule broken.
  static FrameSelection Parse(const std::string& text);
};

}  // namespace rs
