#pragma once
// A file written in many appends, every write(2) and the close(2) checked (formats/checked_file.h
// writes whole files only): the mesh writer streams blocks into temporaries and concatenates them.

#include <filesystem>
#include <string>
#include <string_view>

namespace rs {

/// An output file opened for appending through a buffer. Throws WriteError naming the file when
/// it cannot be created, written or closed. Removes the file when destroyed before Close().
class AppendFile {
 public:
  /// Creates or truncates `path`.
  explicit AppendFile(std::filesystem::path path);
  ~AppendFile();
  AppendFile(const AppendFile&) = delete;
  AppendFile& operator=(const AppendFile&) = delete;

  void Append(std::string_view bytes);
  /// Appends the whole content of the closed file `source`.
  void AppendContentsOf(const std::filesystem::path& source);
  /// Flushes and closes; the file then stays.
  void Close();
  const std::filesystem::path& path() const { return path_; }

 private:
  void Flush();
  void Fail(int error);

  std::filesystem::path path_;
  int fd_ = -1;
  std::string buffer_;
};

}  // namespace rs
