#pragma once
// Offline loop closing over a finished map: candidates by position (the SLAM track itself, the GNSS
// priors) and by appearance (bag of words from the survey's own vocabulary; keyframes of another map
// segment at any age), geometric verification (loop_verification.h), a
// prior distance gate against look-alike places, SE(3) pose-graph optimisation, point correction and
// fusion of the re-observed points (the caller then runs a global BA).

#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/slam_map.h"

namespace rs {

struct LoopClosure;
struct SlamOptions;
struct SlamStatistics;

/// Detects, verifies and closes loops in `map` (poses and points corrected in place).
std::vector<LoopClosure> DetectAndCloseLoops(SlamMap* map, const RectifiedStereo& camera, const ScalePyramid& pyramid,
                                             const SlamOptions& options, SlamStatistics* stats);

}  // namespace rs
