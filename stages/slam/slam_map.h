#pragma once
// The SLAM map: keyframes (pose, features, which map point each feature observes), map points
// (position, representative descriptor, observations) and the covisibility graph. Ids are
// indices into the deques (never reused; removed elements are flagged bad) so iteration order,
// and with it every result, is deterministic.

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "stages/slam/stereo_features.h"

namespace rs {

/// An external pose estimate of one frame (GNSS position, autopilot attitude) in the prior's own
/// world frame (e.g. local ENU). SLAM uses priors relatively (motion between frames, distance between
/// frames), so that frame need not be aligned with the SLAM world.
struct PosePrior {
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();  ///< camera-to-prior-world
  bool has_position = true;                                       ///< translation() is meaningful
  bool has_attitude = false;                                      ///< linear() is meaningful
  double sigma_position_m = 1.0;                                  ///< 1-sigma position uncertainty, m
  double sigma_attitude_rad = 0.01;                               ///< 1-sigma attitude uncertainty, rad
};

/// A 3-D landmark.
struct MapPoint {
  int id = -1;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  ///< position in the SLAM world, m
  cv::Mat descriptor;                                 ///< 1 x 32 representative ORB descriptor (least median distance)
  std::map<int, int> observations;                    ///< keyframe id -> feature index in that keyframe
  int reference_kf = -1;                              ///< keyframe that created it (loop correction moves it along)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< mean viewing direction (unit)
  double min_distance_m = 0, max_distance_m = 0;      ///< scale-invariance distance range
  int visible = 1, found = 1;                         ///< times predicted in view / actually matched (culling ratio)
  bool bad = false;
  int replaced_by = -1;  ///< the point it was merged into (SlamMap::Replace), -1 none
};

/// A keyframe.
struct Keyframe {
  int id = -1;
  int frame_index = -1;  ///< index of the frame (Track call) it was made from
  int64_t t_ns = 0;
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  StereoFeatures features;
  std::vector<int> points;          ///< per feature: map point id or -1
  std::map<int, int> covisibility;  ///< other keyframe id -> shared map points
  int segment = 0;                  ///< map segment (a new one starts when tracking and relocalisation fail)
  std::optional<PosePrior> prior;
  bool bad = false;
  Eigen::Vector3d Center() const { return T_cam_world.inverse().translation(); }
  /// Covisible keyframes by decreasing weight (ties by id), those with weight >= min_weight.
  std::vector<int> BestCovisible(int max_count, int min_weight = 1) const;
};

/// Keyframes + map points.
class SlamMap {
 public:
  std::deque<Keyframe> keyframes;
  std::deque<MapPoint> points;

  int AddPoint(const Eigen::Vector3d& p_world, int kf, int feature);
  void AddObservation(int point, int kf, int feature);
  /// Removes one observation; the point becomes bad when none or a single mono one remains.
  void EraseObservation(int point, int kf);
  void SetBad(int point);
  /// Merges point `from` into `into` (observations, counters); `from` becomes bad.
  void Replace(int from, int into);
  /// Recomputes the covisibility weights of kf and its neighbours' links to it.
  void UpdateCovisibility(int kf);
  /// Representative descriptor, mean viewing direction and distance range of a point.
  void UpdatePointDescriptor(int point);
  void UpdatePointGeometry(int point, const ScalePyramid& pyramid);
};

}  // namespace rs
