#pragma once
// Folders that tests share within one run of a test program (a rendered survey is slow to
// make) and remove when the program exits.

#include <filesystem>
#include <system_error>
#include <vector>

namespace rs::test {

/// Registers `dir` to be removed (recursively) when the test program exits.
inline void RemoveAtExit(const std::filesystem::path& dir) {
  struct Registry {
    std::vector<std::filesystem::path> dirs;
    ~Registry() {
      std::error_code ec;
      for (const auto& d : dirs) std::filesystem::remove_all(d, ec);
    }
  };
  static Registry registry;
  registry.dirs.push_back(dir);
}

}  // namespace rs::test
