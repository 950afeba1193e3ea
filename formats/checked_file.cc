#include "formats/checked_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <optional>

namespace rs {
namespace {

// ROADSURVEY_INJECT_WRITE_FAILURE=<substring>[@<n>], read once per process.
struct InjectedFailure {
  std::string substring;
  int64_t nth = 1;
  std::atomic<int64_t> matched{0};
};

InjectedFailure* Injection() {
  static InjectedFailure* const injection = []() -> InjectedFailure* {
    const char* spec = std::getenv("ROADSURVEY_INJECT_WRITE_FAILURE");
    if (!spec || !*spec) return nullptr;
    auto* f = new InjectedFailure;
    std::string s = spec;
    const auto at = s.rfind('@');
    if (at != std::string::npos && at + 1 < s.size() &&
        s.find_first_not_of("0123456789", at + 1) == std::string::npos) {
      f->nth = std::max<int64_t>(1, std::stoll(s.substr(at + 1)));
      s.resize(at);
    }
    f->substring = s;
    return f;
  }();
  return injection;
}

// True when this write is the one the injection names.
bool InjectFailureHere(const std::filesystem::path& path) {
  InjectedFailure* f = Injection();
  if (!f || path.string().find(f->substring) == std::string::npos) return false;
  return f->matched.fetch_add(1) + 1 == f->nth;
}

}  // namespace

WriteError::WriteError(std::filesystem::path path, std::string reason)
    : std::runtime_error("cannot write " + path.string() + ": " + reason),
      path_(std::move(path)),
      reason_(std::move(reason)) {}

void WriteFileChecked(const std::filesystem::path& path, std::string_view bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw WriteError(path, std::strerror(errno));
  const bool inject = InjectFailureHere(path);
  // An injected failure writes half of the bytes first, as a disk filling up mid-file would.
  const size_t limit = inject ? bytes.size() / 2 : bytes.size();
  size_t done = 0;
  int error = 0;
  while (done < limit) {
    const ssize_t n = ::write(fd, bytes.data() + done, limit - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error = n < 0 ? errno : EIO;
      break;
    }
    done += static_cast<size_t>(n);
  }
  if (!error && inject) error = ENOSPC;
  struct stat st {};
  const bool regular = ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
  if (::close(fd) != 0 && !error) error = errno;  // NFS and some filesystems report here
  if (error) {
    if (regular) ::unlink(path.c_str());  // never a device (/dev/full)
    std::string reason = std::strerror(error);
    if (inject) reason += " (injected by ROADSURVEY_INJECT_WRITE_FAILURE)";
    throw WriteError(path, reason);
  }
}

}  // namespace rs
