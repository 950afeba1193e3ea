#pragma once
// Offline loop closing over a finished map: candidates by position (the SLAM track itself, the GNSS
// priors) and by appearance (bag of words from the survey's own vocabulary; keyframes of another map
// segment at any age), geometric verification (loop_verification.h), a
// prior distance gate against look-alike places, SE(3) pose-graph optimisation, point correction and
// fusion of the re-observed points (the caller then runs a global BA).

#include <atomic>
#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/slam_map.h"

namespace rs {

struct LoopClosure;
struct SlamOptions;
struct SlamStatistics;

/// Detects, verifies and closes loops in `map` (poses and points corrected in place). `loop_accepted`, when
/// given, is set as soon as the first loop passes verification (the map is then going to change), so work
/// started on the unchanged map can stop early; the map is only read until all candidates are verified.
std::vector<LoopClosure> DetectAndCloseLoops(SlamMap* map, const RectifiedStereo& camera, const ScalePyramid& pyramid,
                                             const SlamOptions& options, SlamStatistics* stats,
                                             std::atomic<bool>* loop_accepted = nullptr);

}  // namespace rs
