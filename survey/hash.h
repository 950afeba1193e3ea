#pragma once
// Content keys for the cache: 64-bit xxh3 rendered as 16 hex digits.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace rs {

/// Incremental hash. Each Add() is length-prefixed so ("ab","c") != ("a","bc").
class KeyHasher {
 public:
  KeyHasher();
  ~KeyHasher();
  KeyHasher(const KeyHasher&) = delete;
  KeyHasher& operator=(const KeyHasher&) = delete;

  KeyHasher& Add(std::string_view bytes);
  KeyHasher& Add(int64_t v);
  /// 16 lowercase hex digits.
  std::string Hex() const;

 private:
  void* state_;
};

/// Key of a file or folder as found on disk: relative paths, sizes and
/// modification times of every regular file below it (make-style; contents are
/// not read so thousands of frames fingerprint in milliseconds).
/// Missing paths hash as "missing" so that creating them changes the key.
/// Files under `exclude` (e.g. the survey's own output folder when it lies
/// inside an input folder) are left out.
std::string FingerprintPath(const std::filesystem::path& path, const std::filesystem::path& exclude = {});

}  // namespace rs
