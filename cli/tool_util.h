#pragma once
// Small helpers shared by the file-level tool commands (stereo, segment, eval, bench, log):
// flag parsing, pairing files of two folders, exit-code-preserving error conversion.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "survey/options.h"

namespace rs {

/// Runs a library `Check()` and reports a broken rule as bad usage (exit 2): libraries throw
/// std::invalid_argument, the CLI maps OptionError to 2.
template <class F>
void CheckAsOption(F&& check) {
  try {
    check();
  } catch (const std::invalid_argument& e) {
    throw OptionError(e.what());
  }
}

/// "1280x720" -> (1280, 720). Throws OptionError naming `flag` unless both are whole numbers in [16, 16384].
cv::Size ParseImageSize(const std::string& text, const std::string& flag);

/// One evaluation item: an estimate and the truth it is compared with (plus an optional extra
/// file, e.g. a mask, found by the same name).
struct FilePair {
  std::string name;  ///< file name (the key the two sides were paired by)
  std::filesystem::path est, truth, extra;
};

/// Pairs `est` with `truth`: two files give one pair; two folders give one pair per truth file
/// with extension `ext` (sorted by name), each estimate found by the same file name.
/// `extra` (optional, file or folder like the others) adds a third file by the same name.
/// Throws InputError naming a missing file or folder, OptionError when a file is paired with a folder.
std::vector<FilePair> PairFiles(const std::filesystem::path& est, const std::filesystem::path& truth,
                                const std::string& ext, const std::filesystem::path& extra = {});

/// Decodes an image file exactly as stored (any depth, 1 channel expected when `single_channel`).
/// Throws InputError naming the file when it is missing or does not decode.
cv::Mat ReadImageAnyDepth(const std::filesystem::path& path, bool single_channel);

/// Writes `text` to `path`, or to stdout when path is "-". Throws std::runtime_error on failure.
void WriteTextOutput(const std::string& path, const std::string& text);

/// Lower and upper value among the valid pixels at the given quantiles (for preview colour ranges);
/// (0, 1) when no pixel is valid.
std::pair<double, double> ValidRange(const cv::Mat& values32f, const cv::Mat& valid, double lower_q, double upper_q);

}  // namespace rs
