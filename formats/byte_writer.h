#pragma once
// Building and saving binary log files: the ULog and DataFlash writers and the tests' log
// builders append the same little-endian fields.

#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace rs {

/// A byte string built field by field, little-endian (every host we build for is
/// little-endian, as ULog and DataFlash are).
class LittleEndianBytes {
 public:
  template <typename T>
  LittleEndianBytes& Put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s_.append(b, sizeof(T));
    return *this;
  }
  /// Raw bytes, as they are.
  LittleEndianBytes& Str(const std::string& s) {
    s_ += s;
    return *this;
  }
  /// A fixed-size text field: cut to `n` bytes, NUL padded.
  LittleEndianBytes& Text(const std::string& t, size_t n) {
    std::string f = t.substr(0, n);
    f.resize(n, '\0');
    s_ += f;
    return *this;
  }
  const std::string& str() const { return s_; }
  bool empty() const { return s_.empty(); }
  void clear() { s_.clear(); }

 private:
  std::string s_;
};

/// Opens `path` for binary writing, lets `write` fill the stream, and throws
/// std::runtime_error naming the file when it cannot be opened or written.
template <typename WriteFn>
void WriteBinaryFile(const std::filesystem::path& path, WriteFn&& write) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot open " + path.string() + " for writing");
  write(out);
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace rs
