#pragma once
// Publishing a stage's results under their stable names at the top of the output folder, and
// removing what killed runs left behind. A published name is replaced in one rename: a reader
// sees the old content or the new one, and no temporary name is ever left beside it.

#include <cstdint>
#include <filesystem>
#include <string>

namespace rs {

/// True for names our writers give unfinished work: ".<name>.tmp-<pid>-<n>" (TemporarySibling).
bool IsTemporaryName(const std::string& filename);

/// Makes `link` a copy of `target` (a file or a folder; hard links when possible, else copies),
/// replacing what was there in one rename. A link already pointing at `target` is left as it
/// is. Temporary names inside `target` are not published. Throws on failure, leaving the old
/// `link` in place and no temporary behind.
void PublishFile(const std::filesystem::path& target, const std::filesystem::path& link);

/// Removes, anywhere under `output_dir`, the temporary files and folders and the unfinished
/// re-run folders (work/<stage>/<key>.rerun, .old) of runs that were killed. Call only while
/// holding the output folder's lock (OutputLock): a live run's temporaries look the same.
/// Returns how many were removed.
int64_t RemoveOrphanTemporaries(const std::filesystem::path& output_dir);

}  // namespace rs
