#pragma once
// Offline loop closing over a finished map: candidates by appearance (bag of words from the
// survey's own vocabulary) and by prior proximity, stereo SE(3) RANSAC verification, a prior
// distance gate against look-alike places, SE(3) pose-graph optimisation, point correction and
// fusion of the re-observed points (the caller then runs a global BA).

#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/slam_map.h"

namespace rs {

struct LoopClosure;
struct SlamOptions;
struct SlamStatistics;

/// Stereo SE(3) RANSAC between two keyframes: T_a_b maps keyframe b's camera points into a's.
/// Returns false when fewer than min_inliers survive; pairs gets (feature in a, feature in b).
bool VerifyStereoPair(const Keyframe& a, const Keyframe& b, const StereoCamera& camera, const ScalePyramid& pyramid,
                      int min_inliers, unsigned seed, Eigen::Isometry3d* T_a_b, std::vector<std::pair<int, int>>* pairs);

/// Detects, verifies and closes loops in `map` (poses and points corrected in place).
std::vector<LoopClosure> DetectAndCloseLoops(SlamMap* map, const StereoCamera& camera, const ScalePyramid& pyramid,
                                             const SlamOptions& options, SlamStatistics* stats);

}  // namespace rs
