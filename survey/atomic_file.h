#pragma once
// Writes that are all-or-nothing: a crash (even kill -9) leaves either the old
// file or the new one, never a torn one. Temporary name in the same folder,
// fsync-free rename (POSIX rename is atomic within a filesystem).

#include <nlohmann/json_fwd.hpp>

#include <filesystem>
#include <string_view>

namespace rs {

/// Writes `content` to `path` atomically with the checked writer; creates parent folders.
/// Throws WriteError naming `path` when the disk is full or the write fails.
void WriteFileAtomic(const std::filesystem::path& path, std::string_view content);

/// Pretty-printed JSON, atomically.
void WriteJsonAtomic(const std::filesystem::path& path, const nlohmann::json& j);

/// Reads a JSON file; throws InputError with line/column on parse errors.
nlohmann::json ReadJsonFile(const std::filesystem::path& path);

/// A unique sibling name for temporary output next to `final_path`: ".<name>.tmp-<pid>-<n>"
/// (IsTemporaryName recognises it; a run removes those left by killed runs).
std::filesystem::path TemporarySibling(const std::filesystem::path& final_path);

/// Renames a finished temporary folder into place. If `final_dir` already
/// exists (another worker finished it first), the temporary one is removed.
void CommitDirectory(const std::filesystem::path& tmp_dir, const std::filesystem::path& final_dir);

}  // namespace rs
