#pragma once
// `roadsurvey simulate`: writes a complete survey folder (stereo frames,
// calibration, flight log) with exact ground truth, which `roadsurvey run`
// consumes like a real one. Output layout and formats: docs/simulator.md.

#include <filesystem>
#include <functional>
#include <string>

#include "sim/simulation_options.h"

namespace rs {

/// What Simulate() produced.
struct SimulationSummary {
  std::filesystem::path out_dir;
  int frames = 0;          ///< stereo pairs written
  int damages = 0;         ///< damages in truth/damages.geojson
  int obstacles = 0;       ///< obstacles in the scene
  double render_s = 0;     ///< time spent rendering (both cameras + truth)
  double total_s = 0;      ///< wall time of the whole simulation
  double pairs_per_s = 0;  ///< rendering throughput, stereo pairs per second
  /// "48 stereo pairs, 23 damages, 0 obstacles in 12.3 s (rendering 6.1 pairs/s)".
  std::string BriefReport() const;
};

/// Called after each frame with (frames done, frames total).
using SimulationProgressFn = std::function<void(int done, int total)>;

/// Renders and writes the survey folder `out_dir` (created; existing files are
/// overwritten). Throws OptionError for invalid options and std::runtime_error
/// when a file cannot be written.
SimulationSummary Simulate(const SimulationOptions& options, const std::filesystem::path& out_dir,
                           const SimulationProgressFn& progress = {});

/// Writes the survey.json that makes `out_dir` a survey for `roadsurvey run`, with the rig's
/// georeference options (camera mount, zero lever arm) as a user would write them from the rig's spec.
void WriteSurveyJson(const std::filesystem::path& path, const std::string& name, const SimulationOptions& options);

/// Simulator throughput measured by BenchmarkRender(): whole stereo pairs, i.e.
/// left and right views rendered (1 ray per pixel, truth depth and labels for the
/// left), the truth disparity converted, and the four PNGs (left, right,
/// disparity, mask) encoded and written, exactly as Simulate() does per frame.
struct RenderBenchmark {
  double pairs_per_s = 0;      ///< stereo pairs per wall-clock second
  double pairs_per_cpu_s = 0;  ///< stereo pairs per CPU second (all threads): the figure on a busy machine
  int threads = 0;
  double load_average = -1;  ///< 1-minute load average at the end of the run (-1: unknown)
  /// pairs_per_cpu_s * threads: what `threads` otherwise idle cores deliver.
  double PairsPerSecondOnIdleCores() const { return pairs_per_cpu_s * threads; }
  /// What one timed pair includes, for printing next to the figures.
  static const char* Includes();
};

/// Renders and writes `pairs` stereo pairs of `options` (frames 0, 1, ... as in
/// Simulate(), into a temporary folder that is removed afterwards) on `threads`
/// threads. Not timed: scene construction and one warm-up frame.
RenderBenchmark BenchmarkRender(const SimulationOptions& options, int pairs, int threads);

}  // namespace rs
