#pragma once
// One run per output folder. Two runs writing the same cache and published names would
// overwrite each other's results; the second one is refused with a message naming the first.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

namespace rs {

/// Who holds an output folder: the content of its lock file.
struct LockHolder {
  int64_t pid = 0;
  std::string host;
  std::string started_utc;
  /// "PID 1234 on host survey-pc, started 2026-11-28T02:15:00Z".
  std::string ToString() const;
  /// Whether the process still exists (only decidable on the same host; true when unsure).
  bool MaybeAlive() const;
  /// This process.
  static LockHolder Self(std::string started_utc);
};

/// Another run holds the output folder (exit code 1: the environment, not the input).
class OutputLockedError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Exclusive use of an output folder while it lives: flock(2) on <output>/.roadsurvey.lock, whose
/// content names the holder. The kernel drops the lock when the holder dies (kill -9 included);
/// the file then remains with a dead holder's name and the next run takes it over with a note.
class OutputLock {
 public:
  static constexpr const char* kFileName = ".roadsurvey.lock";

  /// Takes the lock or throws OutputLockedError naming the holder. Creates `output_dir`.
  static OutputLock Acquire(const std::filesystem::path& output_dir, const LockHolder& self);
  OutputLock(OutputLock&& other) noexcept;
  OutputLock& operator=(OutputLock&&) = delete;
  /// Removes the lock file, then releases the lock.
  ~OutputLock();

  /// The holder before us when it died without releasing the lock (kill -9, power loss).
  const std::optional<LockHolder>& taken_over_from() const { return taken_over_from_; }

  /// The holder named in `output_dir`'s lock file, if there is one (it may be stale).
  static std::optional<LockHolder> ReadHolder(const std::filesystem::path& output_dir);

 private:
  OutputLock(int fd, std::filesystem::path path) : fd_(fd), path_(std::move(path)) {}
  int fd_ = -1;
  std::filesystem::path path_;
  std::optional<LockHolder> taken_over_from_;
};

}  // namespace rs
