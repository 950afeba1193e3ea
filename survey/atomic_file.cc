#include "survey/atomic_file.h"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "formats/checked_file.h"
#include "formats/input_error.h"

namespace rs {
namespace fs = std::filesystem;

fs::path TemporarySibling(const fs::path& final_path) {
  static std::atomic<uint64_t> counter{0};
  return final_path.parent_path() /
         fmt::format(".{}.tmp-{}-{}", final_path.filename().string(), ::getpid(), counter.fetch_add(1));
}

void WriteFileAtomic(const fs::path& path, std::string_view content) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  const fs::path tmp = TemporarySibling(path);
  try {
    WriteFileChecked(tmp, content);
  } catch (const WriteError& e) {
    throw WriteError(path, e.reason());  // name the file the user knows, not the temporary
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw WriteError(path, "cannot rename into place: " + ec.message());
  }
}

void WriteJsonAtomic(const fs::path& path, const nlohmann::json& j) { WriteFileAtomic(path, j.dump(2) + "\n"); }

nlohmann::json ReadJsonFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Translate the byte offset into line:column of the user's file.
    int64_t line = 1, column = 1;
    const size_t end = std::min<size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    for (size_t i = 0; i < end; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    std::string msg = e.what();
    const auto pos = msg.find("syntax error");
    throw InputError(InputLocation::Line(path.string(), line, column),
                     "invalid JSON: " + (pos == std::string::npos ? msg : msg.substr(pos)));
  }
}

void CommitDirectory(const fs::path& tmp_dir, const fs::path& final_dir) {
  std::error_code ec;
  fs::rename(tmp_dir, final_dir, ec);
  if (ec) {
    if (fs::exists(final_dir)) {
      fs::remove_all(tmp_dir, ec);
      return;
    }
    throw std::runtime_error(
        fmt::format("cannot commit {} -> {}: {}", tmp_dir.string(), final_dir.string(), ec.message()));
  }
}

}  // namespace rs
