#pragma once
// Test helper: truncated and bit-flipped copies of real sample files. A reader
// must answer each with a track or an rs::InputError, never a crash or another
// exception type.

#include <gtest/gtest.h>
#include "tests/support/test_data.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>

#include "formats/flight_log/flight_track.h"
#include "formats/input_error.h"

namespace rs::testing {

/// The test data root (ROADSURVEY_DATA, else the build-time default).
inline std::filesystem::path DataRoot() { return rs::test::DataRoot(); }

inline std::string Slurp(const std::filesystem::path& p, size_t max_bytes = SIZE_MAX) {
  std::ifstream in(p, std::ios::binary);
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (s.size() > max_bytes) s.resize(max_bytes);
  return s;
}

/// Counts of what the mutated copies produced.
struct MutationStats {
  int parsed = 0;
  int input_errors = 0;
  int input_errors_with_line = 0;
};

/// Runs `read` on `n_trunc` truncations and `n_flips` single-byte corruptions of
/// `text`. Fails the test on any exception other than InputError.
inline MutationStats Mutate(const std::string& text, const std::function<FlightTrack(std::istream&)>& read, int n_trunc,
                            int n_flips, uint32_t seed) {
  MutationStats st;
  auto run = [&](const std::string& s, const std::string& what) {
    std::istringstream in(s);
    try {
      read(in);
      ++st.parsed;
    } catch (const InputError& e) {
      ++st.input_errors;
      st.input_errors_with_line += e.where().line >= 1;
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": non-InputError exception: " << e.what();
    }
  };
  std::mt19937 rng(seed);
  for (int i = 1; i <= n_trunc; ++i) {
    const size_t cut = text.size() * static_cast<size_t>(i) / static_cast<size_t>(n_trunc + 1);
    run(text.substr(0, cut), "truncated at " + std::to_string(cut));
  }
  for (int i = 0; i < n_flips && !text.empty(); ++i) {
    std::string s = text;
    const size_t pos = std::uniform_int_distribution<size_t>(0, s.size() - 1)(rng);
    s[pos] = static_cast<char>(s[pos] ^ (1 << std::uniform_int_distribution<int>(0, 7)(rng)));
    run(s, "bit flip at " + std::to_string(pos));
  }
  return st;
}

}  // namespace rs::testing
