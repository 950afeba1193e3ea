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

std::string FingerprintPath(const std::filesystem::path& path, const std::filesystem::path& exclude) {
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
  std::vector<std::string> files;
  const fs::path excluded = exclude.empty() ? fs::path() : fs::weakly_canonical(exclude);
  for (auto it = fs::recursive_directory_iterator(path, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!excluded.empty() && it->is_directory() && fs::weakly_canonical(it->path()) == excluded) {
      it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file()) files.push_back(fs::relative(it->path(), path).generic_string());
  }
  std::sort(files.begin(), files.end());
  for (const auto& rel : files) add_file(path / rel, rel);
  return h.Hex();
}

}  // namespace rs
