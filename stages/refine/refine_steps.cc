#include "stages/refine/refine_steps.h"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <stdexcept>

#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "stages/refine/child_process.h"
#include "survey/stage.h"

namespace rs {
namespace fs = std::filesystem;

std::vector<int64_t> FrameIdsOfKeyframes(const SlamMapFile& map, const std::vector<FrameRecord>& frames,
                                         const fs::path& map_dir) {
  std::map<int64_t, int64_t> id_at;
  for (const auto& f : frames) id_at.emplace(f.t_ns, f.id.value);
  std::vector<int64_t> ids;
  for (const auto& k : map.keyframes) {
    const auto it = id_at.find(k.t_ns);
    if (it == id_at.end())
      throw InputError(InputLocation::File((map_dir / "keyframes.txt").string()),
                       fmt::format("keyframe {} at t_ns {} is no frame of frames.csv", k.id, k.t_ns));
    ids.push_back(it->second);
  }
  return ids;
}

std::vector<std::string> RigBundleAdjusterArgs(const fs::path& input, const fs::path& rig_config, const fs::path& output,
                                               int max_iterations, double function_tolerance) {
  return {"rig_bundle_adjuster",
          "--input_path", input.string(),
          "--output_path", output.string(),
          "--rig_config_path", rig_config.string(),
          "--estimate_rig_relative_poses", "0",
          "--RigBundleAdjustment.refine_relative_poses", "0",
          "--BundleAdjustment.refine_focal_length", "0",
          "--BundleAdjustment.refine_principal_point", "0",
          "--BundleAdjustment.refine_extra_params", "0",
          "--BundleAdjustment.max_num_iterations", std::to_string(max_iterations),
          "--BundleAdjustment.function_tolerance", fmt::format("{}", function_tolerance),
          "--log_to_stderr", "1"};
}

void RunRigBundleAdjuster(StageContext& ctx, const fs::path& program, const fs::path& input, const fs::path& rig_config,
                          const fs::path& output, int max_iterations, double function_tolerance) {
  fs::create_directories(output);
  const auto args = RigBundleAdjusterArgs(input, rig_config, output, max_iterations, function_tolerance);
  const std::string command = CommandLine(program, args);
  ctx.progress().Start("colmap rig BA", max_iterations, "iterations");
  // Ceres prints one line per iteration that starts with its number.
  const auto on_line = [&](std::string_view line) {
    const size_t i = line.find_first_not_of(' ');
    if (i != std::string_view::npos && i + 1 < line.size() && std::isdigit(static_cast<unsigned char>(line[i])) &&
        line.find("e+") != std::string_view::npos)
      ctx.progress().Advance();
  };
  ChildResult r;
  try {
    r = RunChild(program, args, on_line);
  } catch (const std::system_error& e) {
    ctx.progress().Finish();
    throw std::runtime_error(fmt::format("{} (command: {})", e.what(), command));
  }
  ctx.progress().Finish();
  const fs::path log = ctx.out_dir() / "colmap.log";
  WriteFileChecked(log, "$ " + command + "\n" + r.output);
  if (r.exit_code != 0)
    throw std::runtime_error(fmt::format(
        "COLMAP (Debian package colmap) failed ({}): {}; its output is in {}",
        r.signal ? fmt::format("signal {}", r.signal) : fmt::format("exit status {}", r.exit_code), command,
        log.string()));
  if (!fs::exists(output / "cameras.bin"))
    throw std::runtime_error(fmt::format("COLMAP wrote no model into {} ({}); its output is in {}", output.string(),
                                         command, log.string()));
}

void RoundModel(ColmapModel* model, double step) {
  // + 0.0 turns -0 into 0: a value at zero may come back from COLMAP with either sign.
  const auto round = [step](double v) { return std::round(v / step) * step + 0.0; };
  for (auto& im : model->images) {
    for (int k = 0; k < 4; ++k) im.q_cam_world.coeffs()[k] = round(im.q_cam_world.coeffs()[k]);
    im.q_cam_world.normalize();
    for (int k = 0; k < 3; ++k) im.t_cam_world[k] = round(im.t_cam_world[k]);
  }
  for (auto& p : model->points)
    for (int k = 0; k < 3; ++k) p.xyz[k] = round(p.xyz[k]);
}

RefinedSurvey RestoreGauge(const SlamMapFile& map, const Trajectory& slam_trajectory, const ColmapExport& exported,
                           const ColmapModel& adjusted, GaugeAnchor anchor) {
  const auto T_cam_world_ba = KeyframePosesFromModel(adjusted, exported);
  if (T_cam_world_ba.empty()) throw std::runtime_error("COLMAP returned none of the keyframes");
  // One gauge per map segment: segments share no observation, so each floats on its own.
  std::map<int, std::vector<int>> by_segment;
  for (const auto& [i, T] : T_cam_world_ba) by_segment[map.keyframes[i].segment].push_back(i);
  std::map<int, Eigen::Isometry3d> G_of_segment;
  for (const auto& [segment, members] : by_segment) {
    std::vector<Eigen::Isometry3d> slam, ba;
    for (int i : members) {
      slam.push_back(map.keyframes[i].T_cam_world.inverse());
      ba.push_back(T_cam_world_ba.at(i).inverse());
    }
    G_of_segment[segment] = GaugeTransform(slam, ba, anchor);
  }

  RefinedSurvey out;
  out.map = map;
  std::vector<KeyframeCorrection> corrections;
  for (const auto& [i, T_cam_world] : T_cam_world_ba) {
    const Eigen::Isometry3d T_world_cam = G_of_segment.at(map.keyframes[i].segment) * T_cam_world.inverse();
    const Eigen::Isometry3d T_world_cam_slam = map.keyframes[i].T_cam_world.inverse();
    corrections.push_back({map.keyframes[i].t_ns, T_world_cam * T_world_cam_slam.inverse()});
  }
  // Keyframes COLMAP had no image of (no observation kept) follow their neighbours, like frames.
  Trajectory keyframes_slam;
  for (const auto& k : map.keyframes) keyframes_slam.poses.push_back({k.t_ns, k.T_cam_world.inverse()});
  const Trajectory keyframes_refined = CarryTrajectory(keyframes_slam, corrections);
  std::vector<Eigen::Isometry3d> C_of_keyframe(map.keyframes.size());
  std::map<int, int> index_of_keyframe;
  for (size_t i = 0; i < map.keyframes.size(); ++i) {
    const Eigen::Isometry3d& T_world_cam = keyframes_refined.poses[i].T_world_frame;
    const Eigen::Isometry3d& T_world_cam_slam = keyframes_slam.poses[i].T_world_frame;
    C_of_keyframe[i] = T_world_cam * T_world_cam_slam.inverse();
    out.map.keyframes[i].T_cam_world = T_world_cam.inverse();
    out.max_keyframe_move_m =
        std::max(out.max_keyframe_move_m, (T_world_cam.translation() - T_world_cam_slam.translation()).norm());
    index_of_keyframe[map.keyframes[i].id] = int(i);
  }
  const auto adjusted_points = PointsFromModel(adjusted, exported);
  for (size_t p = 0; p < map.points.size(); ++p) {
    auto& point = out.map.points[p];
    if (point.observations.empty()) continue;
    const int first = index_of_keyframe.at(point.observations.front().keyframe);
    const auto it = adjusted_points.find(int(p));
    // An adjusted point is in its first keyframe's segment's gauge; every track lies in one segment.
    point.p_world = it != adjusted_points.end() ? G_of_segment.count(map.keyframes[first].segment)
                                                      ? G_of_segment.at(map.keyframes[first].segment) * it->second
                                                      : C_of_keyframe[first] * point.p_world
                                                : C_of_keyframe[first] * point.p_world;
  }
  out.trajectory = CarryTrajectory(slam_trajectory, corrections);

  out.colmap = exported.model;  // left and right in pixels, whatever cameras COLMAP adjusted
  for (auto& im : out.colmap.images) {
    const int k = exported.keyframe_of_left_image.at((im.id - 1) / 2);
    im.SetPose(out.map.keyframes[k].T_cam_world);
    if (im.camera_id == kRightCameraId) im.SetPose(exported.rigs.front().cameras.back().T_cam_rig * im.T_cam_world());
  }
  for (auto& p : out.colmap.points) p.xyz = out.map.points[exported.map_point_of_colmap_point.at(p.id - 1)].p_world;
  return out;
}

}  // namespace rs
