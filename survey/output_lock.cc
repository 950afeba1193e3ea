#include "survey/output_lock.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

#include "formats/checked_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

std::string HostName() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "?";
  return buf;
}

std::string ReadAll(int fd) {
  std::string text;
  char buf[512];
  off_t offset = 0;
  for (ssize_t n; (n = ::pread(fd, buf, sizeof buf, offset)) > 0; offset += n) text.append(buf, n);
  return text;
}

std::optional<LockHolder> ParseHolder(const std::string& text) {
  try {
    const auto j = nlohmann::json::parse(text);
    LockHolder h;
    h.pid = j.at("pid").get<int64_t>();
    h.host = j.value("host", "?");
    h.started_utc = j.value("started_utc", "?");
    return h;
  } catch (const std::exception&) {
    return std::nullopt;  // empty (being written) or not ours
  }
}

// The lock file at `path` is still the one open as `fd` (a finishing run removes it before
// releasing the lock, so a waiter may hold a lock on a file no longer in the folder).
bool SameFile(int fd, const fs::path& path) {
  struct stat a {
  }, b{};
  return ::fstat(fd, &a) == 0 && ::stat(path.c_str(), &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

}  // namespace

std::string LockHolder::ToString() const {
  return fmt::format("PID {} on host {}, started {}", pid, host, started_utc);
}

bool LockHolder::MaybeAlive() const {
  if (host != HostName() || pid <= 0) return true;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

LockHolder LockHolder::Self(std::string started_utc) {
  return {static_cast<int64_t>(::getpid()), HostName(), std::move(started_utc)};
}

OutputLock OutputLock::Acquire(const fs::path& output_dir, const LockHolder& self) {
  fs::create_directories(output_dir);
  const fs::path path = output_dir / kFileName;
  for (int attempt = 0;; ++attempt) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw WriteError(path, std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int error = errno;
      std::optional<LockHolder> holder;
      // The holder writes its name right after locking: give it a moment.
      for (int i = 0; i < 20 && !(holder = ParseHolder(ReadAll(fd))); ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      ::close(fd);
      if (error != EWOULDBLOCK) throw WriteError(path, std::string("cannot lock: ") + std::strerror(error));
      throw OutputLockedError(
          fmt::format("output folder {} is in use by another run ({}); wait for it to finish "
                      "or stop it (lock file {})",
                      output_dir.string(), holder ? holder->ToString() : "holder unknown", path.string()));
    }
    if (!SameFile(fd, path)) {
      ::close(fd);  // removed by a run that just finished: lock the new file
      if (attempt < 100) continue;
      throw OutputLockedError("cannot lock output folder " + output_dir.string() + ": the lock file keeps changing");
    }
    OutputLock lock(fd, path);
    lock.taken_over_from_ = ParseHolder(ReadAll(fd));
    const std::string content =
        nlohmann::json{{"pid", self.pid}, {"host", self.host}, {"started_utc", self.started_utc}}.dump() + "\n";
    if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, content.data(), content.size(), 0) != ssize_t(content.size()))
      throw WriteError(path, std::strerror(errno));
    return lock;
  }
}

OutputLock::OutputLock(OutputLock&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      path_(std::move(other.path_)),
      taken_over_from_(std::move(other.taken_over_from_)) {}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());  // before unlocking: a waiter then sees its file is gone and retries
  ::close(fd_);
}

std::optional<LockHolder> OutputLock::ReadHolder(const fs::path& output_dir) {
  const int fd = ::open((output_dir / kFileName).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  auto holder = ParseHolder(ReadAll(fd));
  ::close(fd);
  return holder;
}

}  // namespace rs
