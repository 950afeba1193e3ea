#pragma once
// Where tests find the real public data (../shared/data beside the checkout,
// or $ROADSURVEY_DATA), and how they skip when it is absent so a user's
// checkout without it still passes.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

namespace rs::test {

/// $ROADSURVEY_DATA when set and non-empty, else the build-time default (../shared/data).
inline std::filesystem::path DataRoot() {
  if (const char* env = std::getenv("ROADSURVEY_DATA"); env && *env) return env;
  return ROADSURVEY_DATA_DEFAULT;
}

}  // namespace rs::test

/// Skips the current test with a clear message when `path` does not exist.
#define RS_REQUIRE_DATA(path)                                                                                        \
  do {                                                                                                               \
    if (!std::filesystem::exists(path))                                                                              \
      GTEST_SKIP() << "test data absent: " << (path).string() << " (set ROADSURVEY_DATA to the shared data folder)"; \
  } while (0)
