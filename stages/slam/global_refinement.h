#pragma once
// The final global bundle adjustment of StereoSlam::Finish over keyframes *and* every tracked frame.
// A keyframe-only BA sees each road point from ~2.5 keyframes (a nadir view keeps a point in sight for
// ~9 frames, a keyframe comes every ~4): on a narrow view of flat road a pitch is then nearly
// interchangeable with a shift along track, and that weak mode drifts by degrees over a few hundred
// metres. Each tracked frame's map-point matches (kept by Track) add the views in between, so each
// point is seen from across the whole footprint, and the frames' own poses come out of the same
// optimisation instead of being carried along with their reference keyframe.

#include <atomic>
#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/bundle_adjust.h"
#include "stages/slam/slam_map.h"

namespace rs {

/// One map-point match of a tracked frame that did not become a keyframe (a local-map inlier).
struct FrameObservation {
  float u = 0, v = 0;  ///< left keypoint, px
  float u_right = -1;  ///< right x, px; < 0: mono
  int octave = 0;      ///< pyramid level
  int point = -1;      ///< map point id when matched (followed through SlamMap::Replace)
};

/// A tracked non-key frame in the refinement: its pose (in: initial, out: refined) and its matches.
struct RefinedFrame {
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  std::vector<FrameObservation> observations;
  bool refined = false;  ///< out: the pose was optimised (enough valid observations)
};

/// Residual of the global BA for a pose = (angle-axis, centre) of T_world_cam, with analytic Jacobians
/// (row-major 3x6 and 3x3, either may be null): u and v whitened by r.sqrt_info as in the local BA; for a
/// stereo observation with disparity_sigma_px > 0 the third row is the disparity error
/// (f B / z - (u - u_right)) / disparity_sigma_px, else ReprojectionResidual's right-image u error.
void EvaluateCentreReprojection(const ReprojectionResidual& r, double disparity_sigma_px, const double* pose,
                                const double* point, double* residual, double* J_pose, double* J_point);

/// Optimises every good keyframe except `fixed_kfs`, every frame in `frames` with at least
/// `min_frame_observations` valid matches, and all points they observe; Huber kernel, then
/// observations above the chi-square threshold removed (keyframe ones erased from the map, frame
/// ones dropped) and the problem solved again with half the iterations. Deterministic (one thread).
/// When `cancel` becomes true the solver stops after its current iteration and the function returns
/// with map and frames in an unspecified state (for a caller that discards them).
BundleAdjustSummary GlobalBundleAdjustWithFrames(SlamMap* map, std::vector<RefinedFrame>* frames,
                                                 const RectifiedStereo& camera, const ScalePyramid& pyramid,
                                                 int iterations, const std::vector<int>& fixed_kfs,
                                                 double disparity_sigma_px, int min_frame_observations = 10,
                                                 const std::atomic<bool>* cancel = nullptr);

}  // namespace rs
