#pragma once
// Content keys for the cache: 64-bit xxh3 rendered as 16 hex digits.

#include <cstdint>
#include <filesystem>
#include <functional>
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

/// SHA-256 of `bytes` as 64 lowercase hex digits (FIPS 180-4): the published digest of a file
/// that others check with sha256sum (a learned model's), where a cache key alone would do for xxh3.
std::string Sha256Hex(std::string_view bytes);

/// SHA-256 of a file's contents; throws std::runtime_error naming the file when it cannot be read.
std::string Sha256OfFile(const std::filesystem::path& path);

/// The survey's own output folder as seen from an input's fingerprint: what a run writes there
/// must not change the input's key, wherever the output folder lies.
struct OutputExclusion {
  std::filesystem::path dir;  ///< the output folder (empty: exclude nothing)
  /// Top-level names in `dir` that the output owns (cache, manifest, published outputs,
  /// temporaries). Used when `dir` is the input folder itself (`"output": "."`); when `dir`
  /// lies below the input folder, all of it is left out.
  std::function<bool(const std::string& name)> owned;
};

/// Key of a file or folder as found on disk: relative paths, sizes and
/// modification times of every regular file below it (make-style; contents are
/// not read so thousands of frames fingerprint in milliseconds).
/// Missing paths hash as "missing" so that creating them changes the key.
/// The survey's output (`exclude`) is left out: the whole folder when it lies below `path`,
/// the entries it owns when it is `path` itself.
std::string FingerprintPath(const std::filesystem::path& path, const OutputExclusion& exclude = {});

}  // namespace rs
