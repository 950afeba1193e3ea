#pragma once
// Wall time since a steady-clock instant, in milliseconds: the one timing helper of the stages,
// the evaluators and the benchmarks.

#include <chrono>

namespace rs {

/// Milliseconds of wall time from `t0` to now (steady clock).
inline double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace rs
