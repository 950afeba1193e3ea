#pragma once
// Levenberg-Marquardt for a small bundle adjustment (a local window: a few free poses, thousands of
// points) with fixed-size 3x6 / 3x3 blocks and a dense reduced camera system. Ceres' DENSE_SCHUR runs
// its generic (dynamic-size) Schur eliminator for 3-row residuals and locks a mutex per block update,
// costly for many small blocks. Same cost (0.5 sum of Huber(|r|^2)),
// same parametrisation (angle-axis + translation of T_cam_world, additive updates) and the same
// trust-region rules as Ceres' LM; single-threaded and deterministic (a fixed visiting order).

#include <array>
#include <vector>

#include "stages/slam/bundle_adjust.h"

namespace rs {

/// One observation of a point by a pose: indices into SmallBundleProblem's arrays.
struct SmallBundleObservation {
  int pose = 0, point = 0;
  ReprojectionResidual r;
  double huber = 1;  ///< Huber threshold on |r| (whitened residual)
};

struct SmallBundleProblem {
  std::vector<std::array<double, 6>> poses;   ///< (angle-axis, t) of T_cam_world
  std::vector<char> pose_fixed;               ///< per pose: held constant
  std::vector<std::array<double, 3>> points;  ///< p_world
  std::vector<SmallBundleObservation> observations;
};

struct SmallBundleSummary {
  double initial_cost = 0, final_cost = 0;
  int iterations = 0, successful = 0;
};

/// Minimises the problem in place; max_iterations counts accepted and rejected steps alike (as Ceres).
SmallBundleSummary SolveSmallBundle(SmallBundleProblem* problem, int max_iterations);

}  // namespace rs
