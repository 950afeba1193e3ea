#pragma once
// Building and saving binary log files: the ULog and DataFlash writers and the tests' log
// builders append the same little-endian fields.

#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "formats/checked_file.h"

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

/// Lets `write` fill a stream, then writes it to `path` with the checked writer; throws
/// WriteError naming the file when it cannot be written.
template <typename WriteFn>
void WriteBinaryFile(const std::filesystem::path& path, WriteFn&& write) {
  WriteStreamChecked(path, std::forward<WriteFn>(write));
}

}  // namespace rs
