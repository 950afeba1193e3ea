#include "survey/progress.h"

#include <fmt/format.h>
#include <unistd.h>

namespace rs {
namespace {
// A terminal redraws often; logs get a line only every so often so they stay readable.
constexpr auto kTerminalPeriod = std::chrono::milliseconds(200);
constexpr auto kLogPeriod = std::chrono::seconds(10);
}  // namespace

Progress::Progress(Mode mode, std::FILE* out) : mode_(mode), out_(out) {
  if (mode_ == Mode::kAuto) mode_ = ::isatty(::fileno(out_)) ? Mode::kTerminal : Mode::kLog;
}

void Progress::Start(std::string label, int64_t total, std::string unit) {
  std::lock_guard lock(mutex_);
  label_ = std::move(label);
  unit_ = std::move(unit);
  total_ = total;
  done_ = 0;
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

void Progress::Advance(int64_t n) {
  done_ += n;
  MaybeDraw(false);
}

void Progress::Finish() { MaybeDraw(true); }

std::string Progress::Line() const {
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const int64_t done = done_.load();
  const double rate = elapsed_s > 0 ? done / elapsed_s : 0.0;
  std::string line = fmt::format("{} {}/{} {}", label_, done, total_, unit_);
  if (total_ > 0) line += fmt::format(" ({:.0f}%)", 100.0 * done / total_);
  line += fmt::format(" {:.1f} {}/s", rate, unit_);
  if (rate > 0 && done < total_) line += fmt::format(" ETA {:.0f} s", (total_ - done) / rate);
  return line;
}

void Progress::MaybeDraw(bool force) {
  if (mode_ == Mode::kQuiet) return;
  std::lock_guard lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  const auto period = mode_ == Mode::kTerminal ? std::chrono::duration_cast<std::chrono::milliseconds>(kTerminalPeriod)
                                               : std::chrono::duration_cast<std::chrono::milliseconds>(kLogPeriod);
  if (!force && now - last_draw_ < period) return;
  last_draw_ = now;
  if (mode_ == Mode::kTerminal) {
    fmt::print(out_, "\r\033[K{}{}", Line(), force ? "\n" : "");
  } else {
    fmt::print(out_, "[progress] {}\n", Line());
  }
  std::fflush(out_);
}

}  // namespace rs
