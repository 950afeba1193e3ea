#include "survey/hash.h"

#include <fmt/format.h>
#include <xxhash.h>

#include <algorithm>
#include <vector>

namespace rs {

KeyHasher::KeyHasher() : state_(XXH3_createState()) { XXH3_64bits_reset(static_cast<XXH3_state_t*>(state_)); }
KeyHasher::~KeyHasher() { XXH3_freeState(static_cast<XXH3_state_t*>(state_)); }

KeyHasher& KeyHasher::Add(std::string_view bytes) {
  const uint64_t n = bytes.size();
  XXH3_64bits_update(static_cast<XXH3_state_t*>(state_), &n, sizeof(n));
  XXH3_64bits_update(static_cast<XXH3_state_t*>(state_), bytes.data(), bytes.size());
  return *this;
}

KeyHasher& KeyHasher::Add(int64_t v) { return Add(std::string_view(reinterpret_cast<const char*>(&v), sizeof(v))); }

std::string KeyHasher::Hex() const {
  return fmt::format("{:016x}", XXH3_64bits_digest(static_cast<XXH3_state_t*>(state_)));
}

namespace {

// Canonical form of a path that may not exist yet (the output folder before the first run).
std::filesystem::path Canonical(const std::filesystem::path& p) {
  std::error_code ec;
  const auto c = std::filesystem::weakly_canonical(std::filesystem::absolute(p), ec);
  return ec ? std::filesystem::absolute(p).lexically_normal() : c;
}

// Relative paths of the regular files below `root`, sorted, less the survey's output.
std::vector<std::string> ListInputFiles(const std::filesystem::path& root, const OutputExclusion& exclude) {
  namespace fs = std::filesystem;
  const fs::path root_c = Canonical(root);
  const fs::path out_c = exclude.dir.empty() ? fs::path() : Canonical(exclude.dir);
  const bool output_is_root = !out_c.empty() && out_c == root_c;
  std::vector<std::string> files;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    const fs::path rel = fs::relative(it->path(), root);
    // Lexical: canonicalising every entry would cost a system call per path component.
    const bool excluded = output_is_root ? it.depth() == 0 && exclude.owned && exclude.owned(rel.string())
                                         : !out_c.empty() && (root_c / rel).lexically_normal() == out_c;
    if (excluded) {
      if (it->is_directory()) it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file()) files.push_back(rel.generic_string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

std::string FingerprintPath(const std::filesystem::path& path, const OutputExclusion& exclude) {
  namespace fs = std::filesystem;
  KeyHasher h;
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    h.Add("missing").Add(path.string());
    return h.Hex();
  }
  auto add_file = [&](const fs::path& file, const std::string& rel) {
    std::error_code e;
    const auto size = fs::file_size(file, e);
    const auto mtime = fs::last_write_time(file, e);
    h.Add(rel).Add(static_cast<int64_t>(size)).Add(static_cast<int64_t>(mtime.time_since_epoch().count()));
  };
  if (fs::is_regular_file(status)) {
    add_file(path, path.filename().string());
    return h.Hex();
  }
  for (const auto& rel : ListInputFiles(path, exclude)) add_file(path / rel, rel);
  return h.Hex();
}

}  // namespace rs
