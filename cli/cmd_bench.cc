// roadsurvey bench disparity|simulate|damage: throughput and accuracy figures of the stages'
// algorithms, measured in this process, printed as tables.
#include <fmt/format.h>

#include <cstdlib>
#include <memory>
#include <thread>

#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include "cli/command.h"
#include "cli/tool_util.h"
#include "formats/input_error.h"
#include "formats/stereo/image_io.h"
#include "eval/damage/damage_bench.h"
#include "eval/disparity/disparity_benchmark.h"
#include "formats/disparity/disparity_io.h"
#include "eval/disparity/sim_disparity_eval.h"
#include "sim/simulate.h"
#include "sim/simulation_options.h"

namespace rs {
namespace {

/// The default synthetic road (1280x720) scaled to `size`: disparities, pothole position and
/// size scale with the width, so every size shows the same scene.
SyntheticRoadOptions SyntheticAt(cv::Size size) {
  SyntheticRoadOptions o;
  const double s = double(size.width) / o.width, sv = double(size.height) / o.height;
  o.c0 *= s, o.cv *= s / sv;
  o.pothole_u *= s, o.pothole_v *= sv, o.pothole_radius_px *= s, o.pothole_depth_px *= s;
  o.width = size.width, o.height = size.height;
  return o;
}

/// "LEFT,RIGHT,GT": images and KITTI 16-bit truth of the left view.
StereoPairWithTruth LoadUserPair(const std::string& spec, int min_d, int num_d) {
  const auto c1 = spec.find(','), c2 = c1 == std::string::npos ? c1 : spec.find(',', c1 + 1);
  if (c2 == std::string::npos || spec.find(',', c2 + 1) != std::string::npos)
    throw OptionError(fmt::format("pair '{}' violates LEFT,RIGHT,GT (truth: KITTI 16-bit PNG)", spec));
  StereoPairWithTruth p;
  const std::string lp = spec.substr(0, c1), rp = spec.substr(c1 + 1, c2 - c1 - 1), gp = spec.substr(c2 + 1);
  p.name = std::filesystem::path(lp).stem().string();
  p.left = LoadGray8(lp), p.right = LoadGray8(rp);
  cv::Mat valid;
  p.gt = ReadKittiDisparityPng(gp, &valid);
  if (p.right.size() != p.left.size() || p.gt.size() != p.left.size())
    throw InputError(InputLocation::File(spec), "left, right and truth differ in size");
  p.nonocc = valid;  // no occlusion truth: every truth pixel counts as non-occluded
  p.min_disparity = min_d, p.num_disparities = num_d;
  return p;
}

int HardwareThreads(int threads) {
  return threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency()));
}

}  // namespace

Command BenchCommand() {
  return {
      "bench", "Benchmark the algorithms: disparity (ours vs OpenCV SGBM), simulator rendering, damage detection",
      [](CLI::App& app, const StageRegistry&) -> std::function<int()> {
        app.option_defaults()->always_capture_default();
        app.require_subcommand(1);
        struct DispArgs {
          std::vector<std::string> pairs, sims;
          int sim_step = 1, sim_frames = 0;
          std::string middlebury, synthetic, only;
          int repeat = 3, threads = 0, min_disparity = 0, num_disparities = 128;
        };
        auto d = std::make_shared<DispArgs>();
        CLI::App* disp = app.add_subcommand(
            "disparity", "our GPT-SGM and SGM vs OpenCV SGBM and SGBM_3WAY: time per pair and accuracy");
        disp->add_option("pairs", d->pairs, "LEFT,RIGHT,GT triples (rectified images, KITTI 16-bit truth)");
        disp->add_option(
            "--sim", d->sims,
            "`roadsurvey simulate` folder(s): road D1 and pothole error per survey (docs/stages/disparity.md)");
        disp->add_option("--sim-step", d->sim_step, "every n-th frame of --sim")->check(CLI::Range(1, 100000));
        disp->add_option("--sim-frames", d->sim_frames, "at most this many frames per --sim (0 = all)")
            ->check(CLI::NonNegativeNumber);
        disp->add_option("--middlebury", d->middlebury,
                         "folder with the four Middlebury pairs (shared/data/middlebury)");
        disp->add_option("--synthetic", d->synthetic,
                         "synthetic road pair of this size, WxH (default 1280x720 when nothing else is given)");
        disp->add_option("--repeat", d->repeat, "runs per method and pair (the median is reported)")
            ->check(CLI::Range(1, 1000));
        disp->add_option("--threads", d->threads, "worker threads for all methods (0 = all cores)")
            ->check(CLI::NonNegativeNumber);
        disp->add_option("--only", d->only, "run one method")
            ->check(CLI::IsMember({"gpt-sgm", "sgm", "sgbm", "sgbm-3way"}));
        disp->add_option("--min-disparity", d->min_disparity, "search start of the given pairs, px");
        disp->add_option("--num-disparities", d->num_disparities, "search range of the given pairs, px")
            ->check(CLI::Range(1, 1024));

        struct SimArgs {
          std::string preset = "demo";
          int pairs = 4, threads = 0;
        };
        auto s = std::make_shared<SimArgs>();
        CLI::App* sim = app.add_subcommand("simulate", "stereo pairs (with truth) rendered per second");
        sim->add_option("--preset", s->preset, "simulator preset")->check(CLI::IsMember(PresetNames()));
        sim->add_option("--pairs", s->pairs, "pairs rendered")->check(CLI::Range(1, 10000));
        sim->add_option("--threads", s->threads, "render threads (0 = all cores)")->check(CLI::NonNegativeNumber);

        struct DmgArgs {
          std::string size = "1280x720";
          int frames = 5;
        };
        auto g = std::make_shared<DmgArgs>();
        CLI::App* dmg = app.add_subcommand(
            "damage", "per-frame damage stage time on a synthetic frame (potholes, slab, cracks, noisy disparity)");
        dmg->add_option("--size", g->size, "frame size, WxH");
        dmg->add_option("--frames", g->frames, "frames timed (the median is reported)")->check(CLI::Range(1, 10000));

        return [=]() -> int {
          if (disp->parsed()) {
            std::vector<StereoPairWithTruth> pairs;
            for (const auto& spec : d->pairs) pairs.push_back(LoadUserPair(spec, d->min_disparity, d->num_disparities));
            for (const auto& dir : d->sims) {
              SimulatedPairOptions so;
              so.frame_step = d->sim_step, so.max_frames = d->sim_frames;
              auto sp = LoadSimulatedSurvey(dir, so);
              pairs.insert(pairs.end(), sp.begin(), sp.end());
            }
            if (!d->middlebury.empty()) {
              auto mb = LoadMiddlebury(d->middlebury);
              pairs.insert(pairs.end(), mb.begin(), mb.end());
            }
            if (!d->synthetic.empty() || pairs.empty())
              pairs.push_back(MakeSyntheticRoadPair(
                  SyntheticAt(ParseImageSize(d->synthetic.empty() ? "1280x720" : d->synthetic, "--synthetic"))));
            const int threads = HardwareThreads(d->threads);
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
            cv::setNumThreads(threads);
            const DisparityParams ours;
            const auto results = RunDisparityBenchmark(pairs, ours, d->repeat, d->only);
            fmt::print("{}\n{}\n", FormatBenchmarkTable(results), FormatStepTimes(results));
            if (!d->sims.empty()) fmt::print("{}\n", FormatRoadAccuracyTable(results));
            fmt::print("{} threads, median of {} runs per method and pair\n", threads, d->repeat);
            for (const auto& r : results)
              if (r.Find("sgbm-3way") && r.Find("gpt-sgm"))
                fmt::print("{}: time gpt-sgm / sgbm-3way {:.2f}, sgm / sgbm-3way {:.2f}\n", r.pair,
                           r.Ratio("gpt-sgm", "sgbm-3way"), r.Ratio("sgm", "sgbm-3way"));
            return kExitOk;
          }
          if (sim->parsed()) {
            const SimulationOptions options = PresetOptions(s->preset);
            const int threads = HardwareThreads(s->threads);
            const RenderBenchmark b = BenchmarkRender(options, s->pairs, threads);
            fmt::print(
                "| preset | size | pairs | threads | pairs/s (wall) | pairs per CPU-second | pairs/s on {} idle cores "
                "|\n"
                "|---|---|---|---|---|---|---|\n",
                threads);
            fmt::print("| {} | {}x{} | {} | {} | {:.2f} | {:.2f} | {:.2f} |\n", s->preset, options.image_width,
                       options.image_height, s->pairs, b.threads, b.pairs_per_s, b.pairs_per_cpu_s,
                       b.PairsPerSecondOnIdleCores());
            fmt::print("{}; load average {:.1f}\n", RenderBenchmark::Includes(), b.load_average);
            return kExitOk;
          }
          const cv::Size size = ParseImageSize(g->size, "--size");
          // CPU figures inflate and wall figures wait on a loaded machine: say how loaded.
          double load_before[1] = {-1}, load_after[1] = {-1};
          getloadavg(load_before, 1);
          const DamageBench b = BenchDetectDamage(size.width, size.height, g->frames);
          getloadavg(load_after, 1);
          fmt::print(
              "| size | frames | wall ms/frame (median) | CPU ms/frame (median, all threads) | frames/s (wall) |\n"
              "|---|---|---|---|---|\n");
          fmt::print("| {}x{} | {} | {:.1f} | {:.1f} | {:.1f} |\n", size.width, size.height, g->frames, b.wall_ms,
                     b.cpu_ms, b.wall_ms > 0 ? 1000.0 / b.wall_ms : 0.0);
          fmt::print("passes (wall ms):");
          for (const PassTime& p : b.pass_ms) fmt::print(" {} {:.1f},", p.name, p.ms);
          fmt::print(
              " overlay + JSON {:.1f}; PNG encoding {:.1f} (not included)\nframe: {} potholes, {} cracks, {} other\n",
              b.outputs_ms, b.encode_ms, b.potholes, b.cracks, b.others);
          fmt::print("load average (1 min) {:.1f} before, {:.1f} after; {} hardware threads\n", load_before[0],
                     load_after[0], std::thread::hardware_concurrency());
          return kExitOk;
        };
      }};
}

}  // namespace rs
