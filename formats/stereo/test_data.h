#pragma once
// Test helper: the real-data folder (env ROADSURVEY_DATA, else the build default).

#include <cstdlib>
#include <filesystem>

namespace rs::stereo_test {

inline std::filesystem::path DataRoot() {
  if (const char* env = std::getenv("ROADSURVEY_DATA"); env && *env) return env;
  return ROADSURVEY_DATA_DEFAULT;
}

}  // namespace rs::stereo_test

/// Skips the test when a data folder is absent, so a checkout without ../shared/data passes.
#define RS_REQUIRE_DATA(path)                                                                  \
  do {                                                                                         \
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "test data absent: " << (path).string(); \
  } while (0)
