#include "survey/publish.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <stdio.h>  // renameat2

#include <regex>
#include <vector>

#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

// Hard-links (or copies, across filesystems) every file of `from` into the new folder `to`,
// skipping temporary names.
void LinkTree(const fs::path& from, const fs::path& to) {
  fs::create_directory(to);
  for (const auto& entry : fs::directory_iterator(from)) {
    const std::string name = entry.path().filename().string();
    if (IsTemporaryName(name)) continue;
    const fs::path dest = to / name;
    if (entry.is_directory()) {
      LinkTree(entry.path(), dest);
      continue;
    }
    std::error_code ec;
    fs::create_hard_link(entry.path(), dest, ec);
    if (ec) fs::copy_file(entry.path(), dest);
  }
}

// Puts the finished `tmp` in place of `link` in one rename. rename(2) cannot replace a non-empty
// folder: the two are exchanged atomically instead (renameat2), or, where the filesystem cannot,
// the old one is first moved aside under a temporary name.
void ReplaceWith(const fs::path& tmp, const fs::path& link) {
  if (fs::is_directory(tmp) && fs::exists(fs::symlink_status(link))) {
    if (::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, link.c_str(), RENAME_EXCHANGE) == 0) {
      fs::remove_all(tmp);  // now the old one
      return;
    }
    const fs::path trash = TemporarySibling(link);
    fs::rename(link, trash);
    fs::rename(tmp, link);
    fs::remove_all(trash);
    return;
  }
  fs::rename(tmp, link);
  // rename(2) onto another link to the same file does nothing and leaves `tmp`.
  std::error_code ec;
  fs::remove(tmp, ec);
}

}  // namespace

bool IsTemporaryName(const std::string& filename) {
  static const std::regex kTemporary(R"(\..+\.tmp-[0-9]+-[0-9]+)");
  return std::regex_match(filename, kTemporary);
}

void PublishFile(const fs::path& target, const fs::path& link) {
  std::error_code ec;
  if (!fs::is_directory(target) && fs::equivalent(target, link, ec)) return;  // already published
  const fs::path tmp = TemporarySibling(link);
  try {
    if (fs::is_directory(target)) {
      LinkTree(target, tmp);
    } else {
      fs::create_hard_link(target, tmp, ec);
      if (ec) fs::copy_file(target, tmp);
    }
    ReplaceWith(tmp, link);
  } catch (const fs::filesystem_error& e) {
    fs::remove_all(tmp, ec);
    throw std::runtime_error(fmt::format("cannot publish {}: {}", link.string(), e.code().message()));
  }
}

int64_t RemoveOrphanTemporaries(const fs::path& output_dir) {
  std::vector<fs::path> orphans;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(output_dir, ec); it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    const fs::path& p = it->path();
    const std::string name = p.filename().string();
    const fs::path rel = p.lexically_relative(output_dir);  // work/<stage>/<key>.rerun
    const bool rerun_dir = std::distance(rel.begin(), rel.end()) == 3 && *rel.begin() == "work" &&
                           (p.extension() == ".rerun" || p.extension() == ".old");
    if (IsTemporaryName(name) || rerun_dir) {
      orphans.push_back(p);
      it.disable_recursion_pending();
    }
  }
  for (const auto& p : orphans) fs::remove_all(p);
  return static_cast<int64_t>(orphans.size());
}

}  // namespace rs
