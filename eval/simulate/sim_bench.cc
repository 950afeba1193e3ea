// sim_bench: prints the simulator's throughput (1280x720 stereo pairs per
// second, rendered with truth and written as PNGs) for a preset; with an output
// folder, also times a whole Simulate() run writing every file.
//   Usage: sim_bench [preset] [pairs] [threads] [out_dir]
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "sim/simulate.h"

int main(int argc, char** argv) {
  try {
    const std::string preset = argc > 1 ? argv[1] : "demo";
    const int pairs = argc > 2 ? std::atoi(argv[2]) : 20;
    const int threads = argc > 3 ? std::atoi(argv[3]) : 2;
    const rs::SimulationOptions o = rs::PresetOptions(preset);
    const rs::RenderBenchmark b = rs::BenchmarkRender(o, pairs, threads);
    std::printf(
        "sim_bench preset=%s %dx%d pairs=%d threads=%d: %.2f stereo pairs/s wall, %.2f per CPU-second "
        "-> %.2f pairs/s on %d idle cores (load average %.1f; %s)\n",
        preset.c_str(), o.image_width, o.image_height, pairs, threads, b.pairs_per_s, b.pairs_per_cpu_s,
        b.PairsPerSecondOnIdleCores(), threads, b.load_average, rs::RenderBenchmark::Includes());
    if (argc > 4) {
      const rs::SimulationSummary summary = rs::Simulate(o, argv[4]);
      std::printf("sim_bench Simulate(): %s\n", summary.BriefReport().c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "sim_bench: %s\n", e.what());
    return 1;
  }
}
