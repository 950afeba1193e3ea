#pragma once
// The steps of the refine stage between export and publication.

#include <filesystem>
#include <vector>

#include "formats/colmap/colmap_io.h"
#include "formats/frame_index.h"
#include "formats/slam_map/slam_map_file.h"
#include "formats/trajectory/trajectory.h"
#include "stages/refine/colmap_export.h"
#include "stages/refine/gauge.h"

namespace rs {

class StageContext;

/// The frame id of each keyframe, found by its t_ns in the frame list. InputError (naming `map_dir`)
/// for a keyframe at an instant no frame has.
std::vector<int64_t> FrameIdsOfKeyframes(const SlamMapFile& map, const std::vector<FrameRecord>& frames,
                                         const std::filesystem::path& map_dir);

/// The command-line arguments of `colmap rig_bundle_adjuster` (3.8): intrinsics and the rig's
/// relative pose fixed.
std::vector<std::string> RigBundleAdjusterArgs(const std::filesystem::path& input, const std::filesystem::path& rig_config,
                                               const std::filesystem::path& output, int max_iterations,
                                               double function_tolerance);

/// Runs it, its output into `<out>/colmap.log` and the progress display. Throws std::runtime_error
/// naming the command and the log when it fails.
void RunRigBundleAdjuster(StageContext& ctx, const std::filesystem::path& program, const std::filesystem::path& input,
                          const std::filesystem::path& rig_config, const std::filesystem::path& output,
                          int max_iterations, double function_tolerance);

/// Rounds every pose (translation and quaternion components) and point coordinate of `model` to a
/// multiple of `step` (quaternions renormalised). COLMAP's multithreaded solver sums in thread order,
/// so two runs differ by ~1e-15; rounded to 1e-7 (0.1 µm, ~0.02 arcsec) they agree byte for byte
/// except in the rare case that a value lies within that noise of a rounding boundary.
void RoundModel(ColmapModel* model, double step);

struct RefinedSurvey {
  Trajectory trajectory;  ///< every SLAM frame, carried with its keyframes
  SlamMapFile map;        ///< keyframes and points in the SLAM world frame
  ColmapModel colmap;     ///< the adjusted COLMAP model in the SLAM world frame
  double max_keyframe_move_m = 0;  ///< largest distance between a keyframe's refined and SLAM position
};

/// The adjusted model put back into the SLAM world frame (one GaugeTransform per map segment),
/// the map's points and keyframes replaced by their adjusted values (a point left out of the
/// adjustment moves with its first keyframe) and the trajectory carried (CarryTrajectory).
RefinedSurvey RestoreGauge(const SlamMapFile& map, const Trajectory& slam_trajectory, const ColmapExport& exported,
                           const ColmapModel& adjusted, GaugeAnchor anchor);

}  // namespace rs
