#pragma once
// The one way roadsurvey writes a file: every write(2) and the close(2) are checked, so a full
// disk, a file-size limit or an I/O error is an error naming the file, never a truncated file
// that looks finished. Images are encoded to memory first (formats/image_file.h) and written
// through here too, because cv::imwrite ignores some encoders' write errors (TIFF).
//
// Testing aid: ROADSURVEY_INJECT_WRITE_FAILURE=<substring>[@<n>] makes the n-th (default 1st)
// write whose path contains <substring> fail as a full disk would (ENOSPC, after writing half of
// the bytes). docs/architecture.md, "Guarantees".

#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rs {

/// A write that did not complete (disk full, file too large, I/O error, no permission). Not an
/// InputError: the inputs are fine, the environment is not (exit code 1).
class WriteError : public std::runtime_error {
 public:
  WriteError(std::filesystem::path path, std::string reason);
  const std::filesystem::path& path() const { return path_; }
  /// The system's reason, e.g. "No space left on device".
  const std::string& reason() const { return reason_; }

 private:
  std::filesystem::path path_;
  std::string reason_;
};

/// Creates or truncates `path` and writes `bytes`, retrying short writes. Throws WriteError
/// naming the file and the system's reason; a partly written file is removed.
void WriteFileChecked(const std::filesystem::path& path, std::string_view bytes);

/// Lets `fill` write into a std::ostream (the text formats' writers), then writes the text
/// with WriteFileChecked.
template <typename FillFn>
void WriteStreamChecked(const std::filesystem::path& path, FillFn&& fill) {
  std::ostringstream text;
  fill(text);
  WriteFileChecked(path, text.view());
}

}  // namespace rs
