// slam_bench: accuracy and speed of StereoSlam on the public test sequences and a simulated loop.
//   slam_bench [--data DIR] [--sim-frames N] [--no-sim] [--sim-dir DIR]
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

#include "stages/simulate/simulate.h"
#include "stages/slam/slam_datasets.h"

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::string data = std::getenv("ROADSURVEY_DATA") ? std::getenv("ROADSURVEY_DATA") : "/work/shared/data";
  int sim_frames = 870;
  bool sim = true, only_sim = false;
  fs::path sim_dir = fs::temp_directory_path() / "slam_bench_loop";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--data" && i + 1 < argc) data = argv[++i];
    else if (a == "--sim-frames" && i + 1 < argc) sim_frames = std::atoi(argv[++i]);
    else if (a == "--sim-dir" && i + 1 < argc) sim_dir = argv[++i];
    else if (a == "--no-sim") sim = false;
    else if (a == "--only-sim") only_sim = true;
    else {
      std::cerr << "usage: slam_bench [--data DIR] [--sim-frames N] [--sim-dir DIR] [--no-sim] [--only-sim]\n";
      return 2;
    }
  }
  try {
    rs::SlamOptions opt;
    if (const char* f = std::getenv("SLAM_FEATURES")) opt.features = std::atoi(f);
    if (const char* f = std::getenv("SLAM_KF_GAP")) opt.keyframe_max_gap = std::atoi(f);
    if (const char* f = std::getenv("SLAM_BA_KF")) opt.local_ba_keyframes = std::atoi(f);
    if (const char* f = std::getenv("SLAM_TRIANGULATION")) opt.triangulation_neighbours = std::atoi(f);
    if (!only_sim) {
      const fs::path kitti = fs::path(data) / "kitti_vo_clips/KITTI_sequence_1";
      if (fs::exists(kitti)) {
        const rs::SlamRunReport r = rs::RunKittiOdometry(kitti, opt);
        std::cout << r.Summary("KITTI 06 clip") << "\n";
        if (std::getenv("SLAM_BENCH_VERBOSE"))
          for (const auto& f : r.frames)
            std::cout << "  frame " << f.index << " " << rs::ToString(f.status) << " feat " << f.features << " stereo "
                      << f.stereo_features << " inliers " << f.inliers << (f.keyframe ? " KF" : "") << " err "
                      << r.ate.errors_m[f.index] << " est t " << r.result.frames.poses[f.index].T_world_frame.translation().transpose()
                      << " rot " << Eigen::AngleAxisd(r.result.frames.poses[f.index].T_world_frame.linear()).angle() * 57.3 << "\n";
      }
      const fs::path euroc = fs::path(data) / "euroc_v101_micro";
      if (fs::exists(euroc))
        std::cout << rs::RunEuroc(euroc / "tests/data/MicroEurocDataset", euroc / "open_vins_gt/ov_data/euroc_mav/V1_01_easy.txt", opt)
                         .Summary("EuRoC V1_01 micro")
                  << "\n";
    }
    if (sim) {
      if (!fs::exists(sim_dir / "truth" / "trajectory.tum")) {
        rs::SimulationOptions so = rs::PresetOptions("loop");
        if (sim_frames != so.num_frames) {
          // Shortened loop: a shorter road flown out and back in the same time per metre.
          const double flight_s = sim_frames / so.frame_rate_hz;
          so.road_length_m = 2 * so.start_s_m + so.speed_m_s * (flight_s - so.turn_duration_s) / 2;  // turn at road - start
          so.num_frames = sim_frames;
        }
        std::cout << rs::Simulate(so, sim_dir).BriefReport() << "\n";
      }
      for (bool priors : {false, true}) {
        const rs::SlamRunReport r = rs::RunSimulated(sim_dir, opt, priors);
        std::cout << r.Summary(priors ? "simulated loop (priors 1 m)" : "simulated loop (no priors)") << "\n";
        for (const auto& l : r.result.loops)
          std::cout << "  loop kf " << l.keyframe << " -> " << l.loop_keyframe << ", " << l.inliers << " inliers"
                    << (l.by_prior ? " (prior candidate)" : " (appearance)") << "\n";
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "slam_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
