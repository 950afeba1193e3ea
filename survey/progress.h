#pragma once
// Progress of long work: done/total, rate and ETA. Redrawn in place on a
// terminal; plain periodic log lines otherwise (CI logs, nohup, Slurm).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>

namespace rs {

/// Thread-safe progress counter for one stage's work.
class Progress {
 public:
  enum class Mode { kAuto, kTerminal, kLog, kQuiet };

  /// `out` is where the lines go (stderr by default).
  explicit Progress(Mode mode = Mode::kAuto, std::FILE* out = stderr);

  void Start(std::string label, int64_t total, std::string unit = "frames");
  void Advance(int64_t n = 1);
  void Finish();
  int64_t done() const { return done_.load(); }

  /// "disparity 12/40 (30%) 3.2 frames/s ETA 9 s".
  std::string Line() const;

 private:
  void MaybeDraw(bool force);

  Mode mode_;
  std::FILE* out_;
  std::string label_, unit_;
  int64_t total_ = 0;
  std::atomic<int64_t> done_{0};
  std::chrono::steady_clock::time_point start_, last_draw_;
  std::mutex mutex_;
};

}  // namespace rs
