#pragma once
// Geometric verification of a loop candidate: does keyframe `query` re-observe the place of the older
// keyframe `candidate`? No pose is known between them (an out-and-back flight comes back with the
// image turned by 180 degrees), so: descriptor matching over the two keyframes' stereo features (ratio
// test + the rotation-consistency histogram, which keeps whatever common rotation dominates), stereo
// 3D-3D SE(3) RANSAC refined on reprojection (the two-view estimate), then a guided projection search of
// the candidate's local map into the query and a motion-only refinement; the inlier counts decide.

#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/slam_map.h"

namespace rs {

/// Outcome of VerifyLoopCandidate (figures filled as far as the verification got).
struct LoopVerification {
  int descriptor_matches = 0;  ///< after the ratio test and the rotation histogram
  int ransac_inliers = 0;      ///< of the 3D-3D SE(3) RANSAC (two-way stereo chi-square)
  int two_view_inliers = 0;    ///< RANSAC inliers left after the two-view refinement of the loop edge
  int inliers = 0;             ///< map points matched in the query after guided search + refinement
  /// two_view_inliers or inliers >= min_inliers (the two-view test alone decides where the candidate
  /// has few map points, e.g. far-only points at 25 m altitude or right after a new map segment).
  bool accepted = false;
  /// Query pose in the map's world as seen through the candidate's local map.
  Eigen::Isometry3d T_query_world = Eigen::Isometry3d::Identity();
  /// The loop edge, mapping candidate-camera points into the query camera: through the candidate's
  /// local map (T_query_world * T_candidate_world^-1) when the guided search accepted, else the two-view
  /// estimate. The local map's hundreds of points over a wider area pin the tilt that a narrow nadir
  /// view of flat road leaves nearly interchangeable with a shift.
  Eigen::Isometry3d T_query_candidate = Eigen::Isometry3d::Identity();
  /// Two-view estimate: the candidate's stereo points of the RANSAC inliers reprojected into the query
  /// (motion-only BA); needs no map points (e.g. merging a fresh map segment).
  Eigen::Isometry3d T_query_candidate_two_view = Eigen::Isometry3d::Identity();
  std::vector<std::pair<int, int>> point_matches;  ///< inlier (query feature, map point id)
};

/// Mutual-free nearest-neighbour matches (a feature, b feature) between the listed features of a and
/// b: Hamming <= max_hamming, best < ratio * second best, one match per b feature (the closest), then
/// only the matches in the three dominant bins of the orientation-difference histogram.
std::vector<std::pair<int, int>> MatchByDescriptor(const StereoFeatures& a, const std::vector<int>& a_index,
                                                   const StereoFeatures& b, const std::vector<int>& b_index,
                                                   int max_hamming, double ratio);

/// Verifies that keyframe `query` sees the place of keyframe `candidate` (see the file comment).
/// Deterministic for a seed.
LoopVerification VerifyLoopCandidate(const SlamMap& map, int query, int candidate, const RectifiedStereo& camera,
                                     const ScalePyramid& pyramid, int min_inliers, unsigned seed);

}  // namespace rs
