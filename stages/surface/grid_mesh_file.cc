#include "stages/surface/grid_mesh_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "formats/checked_file.h"

namespace rs {
namespace {
constexpr size_t kBufferBytes = size_t{1} << 20;
}  // namespace

AppendFile::AppendFile(std::filesystem::path path) : path_(std::move(path)) {
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw WriteError(path_, std::strerror(errno));
  buffer_.reserve(kBufferBytes);
}

AppendFile::~AppendFile() {
  if (fd_ < 0) return;
  ::close(fd_);
  ::unlink(path_.c_str());
}

void AppendFile::Append(std::string_view bytes) {
  if (buffer_.size() + bytes.size() > kBufferBytes) Flush();
  if (bytes.size() >= kBufferBytes) {
    buffer_ = bytes;
    Flush();
  } else {
    buffer_.append(bytes);
  }
}

void AppendFile::AppendContentsOf(const std::filesystem::path& source) {
  Flush();
  const int in = ::open(source.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) throw WriteError(path_, "cannot read " + source.string() + ": " + std::strerror(errno));
  std::vector<char> chunk(kBufferBytes);
  while (true) {
    const ssize_t n = ::read(in, chunk.data(), chunk.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      ::close(in);
      throw WriteError(path_, "cannot read " + source.string() + ": " + std::strerror(error));
    }
    if (n == 0) break;
    try {
      Append(std::string_view(chunk.data(), size_t(n)));
    } catch (...) {
      ::close(in);
      throw;
    }
  }
  ::close(in);
}

void AppendFile::Flush() {
  size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) Fail(n < 0 ? errno : EIO);
    done += size_t(n);
  }
  buffer_.clear();
}

void AppendFile::Close() {
  if (fd_ < 0) return;
  Flush();
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {  // NFS and some filesystems report a failed write here
    const int error = errno;
    ::unlink(path_.c_str());
    throw WriteError(path_, std::strerror(error));
  }
}

// The file is left open so that the destructor removes it.
void AppendFile::Fail(int error) {
  buffer_.clear();
  throw WriteError(path_, std::strerror(error));
}

}  // namespace rs
