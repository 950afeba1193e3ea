#pragma once
// The SLAM map as a COLMAP rig problem: keyframes as snapshots of a two-camera rig (left, right),
// map points with the observations that pass the selection below, and back.
//
// COLMAP weighs every observation alike (its rig_bundle_adjuster has no per-observation sigma and,
// in 3.8, no robust loss on its command line), while the SLAM's global BA weighs each by its
// pyramid level (sigma = scale_factor^level px) with a Huber loss. The export therefore keeps the
// observations for which equal weights are right: levels whose sigma is within max_level of
// level 0, and only those consistent with the SLAM solution at their own sigma (chi-square test).

#include <cstdint>
#include <map>
#include <vector>

#include "formats/colmap/colmap_io.h"
#include "formats/slam_map/slam_map_file.h"

namespace rs {

/// Which observations go into the COLMAP problem.
struct ObservationSelection {
  int max_level = 7;               ///< coarser pyramid levels are left out (their sigma is scale_factor^level); 7: all of the default 8
  bool stereo = true;              ///< add each stereo match as an observation in the right image
  double chi2_mono = 5.991;        ///< 95 % of chi-square, 2 dof: (du² + dv²) / sigma² above this is an outlier
  double chi2_stereo = 7.815;      ///< 95 % of chi-square, 3 dof: with the right image's du
  int min_keyframes = 2;           ///< a point is kept when its kept observations span this many keyframes
  /// Give COLMAP one camera per pyramid level, its pixels scaled by 1/sigma (focal length, principal
  /// point and the observations alike), so that COLMAP's residuals are whitened by each level's sigma.
  bool level_weighting = true;
};

/// What the export kept and left out.
struct ExportCounts {
  int64_t observations = 0;       ///< every observation in the map
  int64_t kept_left = 0;          ///< left-image observations exported
  int64_t kept_right = 0;         ///< right-image observations exported
  int64_t dropped_level = 0;      ///< above max_level
  int64_t dropped_outlier = 0;    ///< failed the chi-square test (or behind the camera)
  int64_t dropped_weak_point = 0; ///< passed, but their point spans too few keyframes
  int64_t points_kept = 0;
  int64_t points_dropped = 0;
};

struct ColmapExport {
  ColmapModel model;             ///< left and right images in pixels: what is published and scored
  std::vector<ColmapRig> rigs;   ///< its rig (left, right)
  ColmapModel problem;           ///< what COLMAP adjusts: `model`, or per level cameras (level_weighting)
  std::vector<ColmapRig> problem_rigs;
  int images_per_keyframe = 2;   ///< problem image id = 1 + images_per_keyframe * i + 2 * level + side
  std::vector<std::vector<int>> level_of_point2d;  ///< per `model` image, each 2D point's pyramid level
  std::vector<int> keyframe_of_left_image;  ///< keyframe index in the map for model image id 2i+1 (left), 2i+2 (right)
  std::vector<int> map_point_of_colmap_point;  ///< map point index of COLMAP point id k+1
  ExportCounts counts;
};

inline constexpr uint32_t kLeftCameraId = 1, kRightCameraId = 2;

/// `frame_of_keyframe[i]` is keyframe i's frame id (image names "left/<id, 6 digits>.png").
/// Throws std::invalid_argument when the map has no camera baseline.
ColmapExport ExportToColmap(const SlamMapFile& map, const std::vector<int64_t>& frame_of_keyframe,
                            const ObservationSelection& selection);

/// Reprojection statistics of every observation in a model (its own poses, points and cameras).
struct ReprojectionStats {
  int64_t observations = 0;
  double rmse_px = 0;  ///< sqrt(mean(du² + dv²))
};
ReprojectionStats ModelReprojection(const ColmapModel& model);

/// The world -> left camera pose of each keyframe in a model exported by ExportToColmap (after
/// COLMAP moved it), by keyframe index; and each exported point's position, by map point index.
std::map<int, Eigen::Isometry3d> KeyframePosesFromModel(const ColmapModel& model, const ColmapExport& exported);
std::map<int, Eigen::Vector3d> PointsFromModel(const ColmapModel& model, const ColmapExport& exported);

}  // namespace rs
