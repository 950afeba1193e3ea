#include "stages/refine/refine_stage.h"

#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>

#include "formats/checked_file.h"
#include "formats/colmap/colmap_io.h"
#include "formats/slam_map/slam_map_file.h"
#include "formats/trajectory/tum_trajectory.h"
#include "stages/refine/child_process.h"
#include "stages/refine/refine_steps.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

const OptionTable<ObservationSelection>& SelectionTable() {
  static const auto t =
      OptionTable<ObservationSelection>()
          .Add("max_level", &ObservationSelection::max_level,
               "observations from coarser pyramid levels are left out (COLMAP weighs all alike; a level's sigma is "
               "scale_factor^level px)")
          .Min(0)
          .Add("stereo", &ObservationSelection::stereo,
               "add each stereo match as an observation in the right image (the rig then carries the stereo depth)")
          .Add("chi2_mono", &ObservationSelection::chi2_mono,
               "outlier when (du² + dv²) / sigma² in the SLAM solution exceeds this (95 % of chi-square, 2 dof)")
          .Above(0)
          .Add("chi2_stereo", &ObservationSelection::chi2_stereo,
               "the same with the right image's du (95 % of chi-square, 3 dof)")
          .Above(0)
          .Add("min_keyframes", &ObservationSelection::min_keyframes,
               "a point is exported when its kept observations span at least this many keyframes")
          .Min(1)
          .Add("level_weighting", &ObservationSelection::level_weighting,
               "one COLMAP camera per pyramid level with its pixels scaled by 1/sigma, so that each residual is "
               "weighted by its level's sigma as in the SLAM's own BA");
  return t;
}

std::string ColmapMissing(const std::string& program) {
  return fmt::format(
      "the COLMAP program '{}' (for `{} rig_bundle_adjuster`) was not found: install the Debian package colmap (apt-get install colmap), set "
      "refine.colmap_program to its path, or set refine.enabled = false to pass the SLAM trajectory through",
      program, program);
}

// `why` goes into the manifest's warnings; refine.json says whether refinement was enabled.
void PassThrough(StageContext& ctx, const fs::path& slam_dir, bool enabled, const std::string& why) {
  // Checked first (a bad trajectory fails here as it would in a refinement), then copied byte for byte.
  ReadTumTrajectory(slam_dir / "trajectory.tum");
  std::ifstream in(slam_dir / "trajectory.tum", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  WriteFileChecked(ctx.out_dir() / "trajectory_refined.tum", bytes);
  WriteSlamMap(ctx.out_dir() / "map", ReadSlamMap(slam_dir / "map"));
  ctx.summary().counts["refined"] = false;
  ctx.Warn(why + ": the SLAM trajectory and map are passed through unchanged");
  WriteJsonAtomic(ctx.out_dir() / "refine.json", {{"enabled", enabled}, {"refined", false}, {"reason", why}});
}

}  // namespace

void RefineOptions::Check() const {
  if (colmap_program.empty()) throw OptionError("refine.colmap_program is empty");
  if (selection.chi2_stereo < selection.chi2_mono)
    throw OptionError(fmt::format("refine.chi2_stereo = {} violates chi2_stereo >= chi2_mono (chi2_mono = {})",
                                  selection.chi2_stereo, selection.chi2_mono));
}

const OptionTable<RefineOptions>& RefineOptions::Table() {
  static const auto t =
      OptionTable<RefineOptions>()
          .Add("enabled", &RefineOptions::enabled,
               "run COLMAP's rig bundle adjustment; false passes the SLAM trajectory and map through")
          .Add("colmap_program", &RefineOptions::colmap_program,
               "the COLMAP executable: a name looked up in PATH or a path (Debian package colmap, 3.8)")
          .Include("", &RefineOptions::selection, SelectionTable())
          .Add("max_iterations", &RefineOptions::max_iterations, "COLMAP bundle adjustment iterations at most")
          .Min(1)
          .Add("function_tolerance", &RefineOptions::function_tolerance,
               "the adjustment stops when an iteration lowers the cost by less than this fraction (Ceres' default; "
               "COLMAP's own default 0 runs every iteration)")
          .Min(0)
          .AddEnum("anchor", &RefineOptions::anchor,
                   {{"keyframes", GaugeAnchor::kKeyframes}, {"first_keyframe", GaugeAnchor::kFirstKeyframe}},
                   "how the result is put back into the SLAM world frame: the rigid motion that best maps all "
                   "refined keyframe poses onto the SLAM ones (per map segment), or the first keyframe kept fixed");
  return t;
}

StageInfo RefineStage::Info() {
  StageInfo info;
  info.name = "refine";
  info.version = 1;
  info.doc =
      "Bundle adjustment of the SLAM map by COLMAP's rig bundle adjuster (left and right camera as a rig of fixed "
      "baseline, intrinsics fixed), put back into the SLAM world frame; every frame follows its keyframes.";
  info.inputs = {"frames", "map", "trajectory"};
  info.outputs = {"trajectory_refined", "refined_map"};
  info.published = {{"trajectory_refined.tum", "trajectory_refined.tum"}, {"colmap", "colmap"}};
  info.per_frame = false;
  return info;
}

void RefineStage::ValidateInputs(const SurveyFile&, const RefineOptions& o, ValidationDepth,
                                 ProblemList& problems) const {
  if (o.enabled && !FindProgram(o.colmap_program))
    problems.Error(InputLocation::File(o.colmap_program), ColmapMissing(o.colmap_program));
}

void RefineStage::Run(StageContext& ctx, const RefineOptions& o) const {
  const fs::path slam_dir = ctx.input_dir("map");
  if (!o.enabled) return PassThrough(ctx, slam_dir, false, "refine.enabled = false");
  const auto program = FindProgram(o.colmap_program);
  if (!program) throw InputError(InputLocation::File(o.colmap_program), ColmapMissing(o.colmap_program));

  const auto t0 = std::chrono::steady_clock::now();
  const SlamMapFile map = ReadSlamMap(slam_dir / "map");
  const Trajectory slam_trajectory = ReadTumTrajectory(ctx.input_dir("trajectory") / "trajectory.tum");
  const auto frames = ReadFrameIndex(ctx.input_dir("frames") / "frames.csv");
  const ColmapExport exported = ExportToColmap(map, FrameIdsOfKeyframes(map, frames, slam_dir / "map"), o.selection);
  // A bundle adjustment needs points seen from two keyframes (COLMAP aborts on an empty rig).
  if (exported.counts.points_kept == 0)
    return PassThrough(ctx, slam_dir, true,
                       fmt::format("nothing to adjust: no map point is seen by {} keyframes ({} keyframes in the map)",
                                   o.selection.min_keyframes, map.keyframes.size()));
  const fs::path in_dir = ctx.out_dir() / "colmap_input", ba_dir = ctx.out_dir() / "colmap_ba";
  WriteColmapModel(in_dir, exported.problem, ColmapFormat::kBinary);
  WriteFileChecked(ctx.out_dir() / "rig_config.json", ColmapRigConfigJson(exported.problem_rigs));
  ctx.Time("export", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());

  const auto t1 = std::chrono::steady_clock::now();
  RunRigBundleAdjuster(ctx, *program, in_dir, ctx.out_dir() / "rig_config.json", ba_dir, o.max_iterations,
                       o.function_tolerance);
  ctx.Time("colmap", std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());

  const auto t2 = std::chrono::steady_clock::now();
  ColmapModel adjusted = ReadColmapModel(ba_dir);
  RoundModel(&adjusted, 1e-7);  // reruns agree byte for byte (refine_steps.h)
  const RefinedSurvey refined = RestoreGauge(map, slam_trajectory, exported, adjusted, o.anchor);
  WriteTumTrajectory(ctx.out_dir() / "trajectory_refined.tum", refined.trajectory);
  WriteSlamMap(ctx.out_dir() / "map", refined.map);
  WriteColmapModel(ctx.out_dir() / "colmap", refined.colmap, ColmapFormat::kBinary);
  WriteFileChecked(ctx.out_dir() / "colmap" / "rig_config.json", ColmapRigConfigJson(exported.rigs));
  ctx.Time("import", std::chrono::duration<double>(std::chrono::steady_clock::now() - t2).count());

  const ReprojectionStats before = ModelReprojection(exported.model), after = ModelReprojection(refined.colmap);
  const ExportCounts& c = exported.counts;
  ctx.summary().counts["refined"] = true;
  ctx.Count("keyframes", static_cast<double>(map.keyframes.size()));
  ctx.Count("frames", static_cast<double>(refined.trajectory.poses.size()));
  ctx.Count("observations", static_cast<double>(c.observations));
  ctx.Count("observations_left", static_cast<double>(c.kept_left));
  ctx.Count("observations_right", static_cast<double>(c.kept_right));
  ctx.Count("dropped_level", static_cast<double>(c.dropped_level));
  ctx.Count("outliers", static_cast<double>(c.dropped_outlier));
  ctx.Count("dropped_weak_point", static_cast<double>(c.dropped_weak_point));
  ctx.Count("points", static_cast<double>(c.points_kept));
  ctx.Count("reprojection_rmse_px_before", before.rmse_px);
  ctx.Count("reprojection_rmse_px_after", after.rmse_px);
  ctx.Count("largest_keyframe_move_m", refined.max_keyframe_move_m);
  WriteJsonAtomic(ctx.out_dir() / "refine.json",
                  {{"enabled", true},
                   {"reprojection_rmse_px", {{"before", before.rmse_px}, {"after", after.rmse_px}}},
                   {"image_observations", before.observations},
                   {"map_observations", c.observations},
                   {"kept", {{"left", c.kept_left}, {"right", c.kept_right}, {"points", c.points_kept}}},
                   {"dropped",
                    {{"level", c.dropped_level},
                     {"outlier", c.dropped_outlier},
                     {"weak_point", c.dropped_weak_point},
                     {"points", c.points_dropped}}},
                   {"anchor", o.anchor == GaugeAnchor::kKeyframes ? "keyframes" : "first_keyframe"},
                   {"largest_keyframe_move_m", refined.max_keyframe_move_m}});
}

}  // namespace rs
