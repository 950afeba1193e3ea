#pragma once
// The SLAM map as the slam stage publishes it (`map/`): keyframe poses, map points and every
// observation with its pyramid level and stereo match. Later stages (refine, georeference) read
// it through here. Layout, one folder:
//   map.json       format, rectified camera, scale pyramid
//   keyframes.txt  "id t_ns segment  tx ty tz qx qy qz qw" (T_cam_world: world -> left camera)
//   points.txt     "id x y z  n  (keyframe u v level u_right) x n" (u_right < 0: no stereo match)
// docs/outputs.md, "slam map".

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace rs {

/// One sighting of a map point in a keyframe.
struct SlamMapObservation {
  int keyframe = -1;          ///< keyframe id
  double u_px = 0, v_px = 0;  ///< left rectified image, level-0 pixels
  int level = 0;              ///< ORB pyramid level of the keypoint (sigma = scale_factor^level px)
  double u_right_px = -1;     ///< matched x in the right rectified image (same row); < 0: none
};

struct SlamMapKeyframe {
  int id = -1;
  int64_t t_ns = 0;  ///< capture time; the same instant appears in trajectory.tum
  int segment = 0;   ///< map segment (a new one starts when tracking and relocalisation fail)
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();  ///< world -> left camera
};

struct SlamMapPoint {
  int id = -1;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  ///< SLAM world, m
  std::vector<SlamMapObservation> observations;
};

/// The rectified left camera; the right one has the same intrinsics, shifted by baseline_m along x.
struct SlamMapCamera {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< px
  double baseline_m = 0;
};

struct SlamMapFile {
  SlamMapCamera camera;
  double scale_factor = 1.2;  ///< pyramid scale ratio between levels
  int pyramid_levels = 8;
  std::vector<SlamMapKeyframe> keyframes;  ///< by time
  std::vector<SlamMapPoint> points;

  /// Keypoint position sigma at a pyramid level, px (1 px at level 0).
  double LevelSigmaPx(int level) const;
  /// The keyframe with this id, or nullptr.
  const SlamMapKeyframe* FindKeyframe(int id) const;
};

/// Writes map.json, keyframes.txt and points.txt into `dir` (created) through the checked writer.
void WriteSlamMap(const std::filesystem::path& dir, const SlamMapFile& map);

/// Reads a map folder. Throws InputError naming the file and line on missing or malformed content, an
/// observation of an unknown keyframe, or a level outside the pyramid.
SlamMapFile ReadSlamMap(const std::filesystem::path& dir);

}  // namespace rs
