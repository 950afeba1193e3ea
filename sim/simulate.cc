#include "sim/simulate.h"

#include <chrono>
#include <ctime>
#include <fstream>
#include <stdexcept>

#include <stdlib.h>  // getloadavg
#include <unistd.h>  // getpid

#include <GeographicLib/LocalCartesian.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "formats/flight_log/dataflash/dataflash_writer.h"
#include "formats/flight_log/track_csv.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/flight_log/ulog/ulog_writer.h"
#include "sim/flight_log_sim.h"
#include "sim/flight_path.h"
#include "sim/frame_writer.h"
#include "sim/road_scene.h"
#include "sim/stereo_renderer.h"
#include "sim/truth_writers.h"

namespace rs {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

double Seconds(Clock::time_point a) { return std::chrono::duration<double>(Clock::now() - a).count(); }

/// Road distance range whose damage the cameras can see.
void ViewRange(const SimulationOptions& o, const sim::FlightPath& path, double* s0, double* s1) {
  if (o.platform == "car") {
    *s0 = path.s_first() + 2;
    *s1 = path.s_last_max() + 25;
  } else {
    const double reach = 0.45 * o.altitude_m * (o.image_height / o.focal_px) + 0.5;
    *s0 = path.s_first() - reach;
    *s1 = path.s_last_max() + reach;
  }
  *s0 = std::max(*s0, 1.0);
  *s1 = std::min(*s1, o.road_length_m - 1.0);
}

}  // namespace

std::string SimulationSummary::BriefReport() const {
  return fmt::format("{} stereo pairs, {} damages, {} obstacles in {:.1f} s (rendering {:.1f} pairs/s) -> {}", frames,
                     damages, obstacles, total_s, pairs_per_s, out_dir.string());
}

void WriteSurveyJson(const fs::path& path, const std::string& name, const SimulationOptions& o) {
  // The mount row by row; the antenna sits at the left camera (flight_log_sim.cc).
  const Eigen::Matrix3d R = sim::FlightPath::MountRotation(o.camera_pitch_deg);
  std::string axes;
  for (int i = 0; i < 9; ++i) axes += fmt::format("{}{:.12g}", i == 0 ? "" : i % 3 == 0 ? ", " : ",", R(i / 3, i % 3));
  const nlohmann::json georeference = {
      {"camera_axes_in_body", axes}, {"lever_arm_x_m", 0.0}, {"lever_arm_y_m", 0.0}, {"lever_arm_z_m", 0.0}};
  const nlohmann::json j = {{"name", name},
                            {"inputs",
                             {{"frames", {{"path", "."}}},
                              {"calibration", {{"path", "calibration.yaml"}}},
                              {"flight_log", {{"path", "flight_log.csv"}}}}},
                            {"output", "out"},
                            {"stages",
                             {{"georeference", georeference},
                              // The report charts the cameras' error against the simulator's truth.
                              {"report", {{"reference_trajectory", "truth/reference_trajectory.csv"}}}}}};
  std::ofstream f(path);
  f << j.dump(2) << "\n";
  if (!f) throw std::runtime_error("cannot write " + path.string());
}

SimulationSummary Simulate(const SimulationOptions& o, const fs::path& out, const SimulationProgressFn& progress) {
  o.Check();
  const auto t_start = Clock::now();
  SimulationSummary summary;
  summary.out_dir = out;

  const sim::RoadGeometry road(o);
  const sim::FlightPath path(o, road);
  double s0, s1;
  ViewRange(o, path, &s0, &s1);
  const sim::RoadScene scene(o, s0, s1);
  const StereoCalibration calib = sim::MakeCalibration(o);
  const sim::StereoRenderer renderer(scene, o, calib);
  const GeographicLib::LocalCartesian enu(o.origin_lat_deg, o.origin_lon_deg, o.origin_h_m);

  const sim::FrameWriter writer(o, out, calib.left.fx * calib.BaselineM());
  std::ofstream ts(out / "timestamps.csv");
  ts << "filename,t_ns\n";
  std::vector<int64_t> cam_t_ns;
  std::vector<Eigen::Isometry3d> poses;
  const double render_s =
      sim::RenderAndWriteFrames(o, path, renderer, writer, 0, o.num_frames, [&](int k, const std::string& name) {
        cam_t_ns.push_back(sim::CameraTimeNs(o, k));
        const auto exposure = sim::ExposurePoses(o, path, k);
        poses.push_back(exposure[exposure.size() / 2]);
        ts << name << writer.ext() << "," << cam_t_ns.back() << "\n";
        if (progress) progress(k + 1, o.num_frames);
      });
  ts.close();
  if (!ts) throw std::runtime_error("cannot write " + (out / "timestamps.csv").string());

  WriteCalibrationYaml(out / "calibration.yaml", calib);
  const FlightTrack track = sim::SimulateFlightLog(o, path, enu);
  {
    std::ofstream f(out / "flight_log.csv");
    WriteTrackCsv(f, track);
    std::ofstream g(out / "flight_log.gpx");
    sim::WriteGpx(g, track, "roadsurvey simulate " + o.preset);
    if (!f || !g) throw std::runtime_error("cannot write the flight log in " + out.string());
    // The same track in the autopilot formats the ingest reads (log clock, like the CSV).
    UlogWriteOptions ulog;
    ulog.sys_name = "roadsurvey-simulator";
    ulog.geoid_height_m = sim::kSimGeoidHeightM;
    WriteUlogTrack(out / "flight_log.ulg", track, ulog);
    DataflashWriteOptions bin;
    bin.geoid_height_m = sim::kSimGeoidHeightM;
    WriteDataflashTrack(out / "flight_log.bin", track, bin);
  }
  sim::WriteTum(out / "truth/trajectory.tum", cam_t_ns, poses);
  sim::WriteReferenceTrajectory(out / "truth/reference_trajectory.csv", cam_t_ns, poses, enu);
  sim::WriteDamagesGeoJson(out / "truth/damages.geojson", scene, enu);
  const double corridor = road.half_width() + road.kerb_width() + o.verge_width_m;
  sim::WriteRoadPly(out / "truth/road_surface.ply", scene, s0, s1, corridor, o.mesh_resolution_m);
  sim::WriteGeoreference(out / "truth/georeference.json", o);
  {
    nlohmann::json scene_json = {{"format", "roadsurvey-simulation-v1"},
                                 {"options", SimulationOptions::Table().ToJson(o)},
                                 {"damage_s_range_m", {s0, s1}},
                                 {"flight_s_range_m", {path.s_first(), path.s_last_max()}},
                                 {"log_clock", "UTC; camera clock = log clock + options.clock_offset_s"},
                                 {"gnss_antenna", "at the left camera centre (zero lever arm)"},
                                 {"T_body_cam",
                                  {{"convention", "body FRD, camera OpenCV (x right, y down, z forward)"},
                                   {"R_row_major", std::vector<double>(path.T_body_cam().linear().data(),
                                                                       path.T_body_cam().linear().data() + 9)}}}};
    // Eigen is column-major: transpose so the list reads row by row.
    const Eigen::Matrix3d Rt = path.T_body_cam().linear().transpose();
    scene_json["T_body_cam"]["R_row_major"] = std::vector<double>(Rt.data(), Rt.data() + 9);
    nlohmann::json obstacles = nlohmann::json::array();
    for (const auto& ob : scene.obstacles()) {
      obstacles.push_back({{"name", ob.name},
                           {"kind", ob.kind == sim::Obstacle::Kind::kBox ? "box" : "cylinder"},
                           {"centre_enu_m", {ob.centre.x(), ob.centre.y(), ob.centre.z()}},
                           {"half_size_m", {ob.half_size.x(), ob.half_size.y(), ob.half_size.z()}}});
    }
    scene_json["obstacles"] = obstacles;
    std::ofstream f(out / "truth/scene.json");
    f << scene_json.dump(2) << "\n";
    if (!f) throw std::runtime_error("cannot write scene.json");
  }
  WriteSurveyJson(out / "survey.json", "simulated-" + o.preset, o);

  summary.frames = o.num_frames;
  summary.damages = static_cast<int>(scene.damages().size());
  summary.obstacles = static_cast<int>(scene.obstacles().size());
  summary.render_s = render_s;
  summary.pairs_per_s = render_s > 0 ? o.num_frames / render_s : 0;
  summary.total_s = Seconds(t_start);
  return summary;
}

const char* RenderBenchmark::Includes() {
  return "per pair: left + right rendered with truth, disparity converted, 4 PNGs encoded and written";
}

RenderBenchmark BenchmarkRender(const SimulationOptions& o, int pairs, int threads) {
  o.Check();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(std::max(1, threads)));
  const sim::RoadGeometry road(o);
  const sim::FlightPath path(o, road);
  double s0, s1;
  ViewRange(o, path, &s0, &s1);
  const sim::RoadScene scene(o, s0, s1);
  const StereoCalibration calib = sim::MakeCalibration(o);
  const sim::StereoRenderer renderer(scene, o, calib);
  const fs::path dir = fs::temp_directory_path() / fmt::format("roadsurvey-sim-bench-{}", ::getpid());
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  } cleanup{dir};
  const sim::FrameWriter writer(o, dir, calib.left.fx * calib.BaselineM());
  sim::RenderAndWriteFrames(o, path, renderer, writer, 0, 1);  // warm-up
  const auto t0 = Clock::now();
  const std::clock_t c0 = std::clock();  // process CPU time, all threads
  sim::RenderAndWriteFrames(o, path, renderer, writer, 0, pairs);
  RenderBenchmark b;
  b.pairs_per_cpu_s = pairs / (static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  b.pairs_per_s = pairs / Seconds(t0);
  b.threads = std::max(1, threads);
  double load[1];
  if (::getloadavg(load, 1) == 1) b.load_average = load[0];
  return b;
}

}  // namespace rs
