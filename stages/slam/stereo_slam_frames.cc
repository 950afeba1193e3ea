// StereoSlam's non-key frames after the global BA. A frame keeps its pose relative to its reference
// keyframe from tracking time, when the map had been neither closed nor bundle-adjusted as a whole and
// its stereo matches still carried the uncorrected disparities (a disparity offset is a scale error:
// KITTI's 0.24 px is ~1.4 % of the motion, up to 7 cm over a keyframe gap of 5 frames). So each tracked
// frame is solved again by motion-only BA against the final map points it matched, with the corrected
// disparities. (With global_ba_frames the global BA has refined the frames already.)
#include <vector>

#include "stages/slam/pose_optimizer.h"
#include "stages/slam/stereo_slam_internal.h"

namespace rs {

void StereoSlam::Impl::RefineFramesOnFinalMap() {
  for (FrameRecord& r : records) {
    if (r.observations.empty()) continue;
    std::vector<PoseObservation> obs;
    for (const FrameObservation& o : r.observations) {
      int p = o.point;  // followed through fusions (SlamMap::Replace)
      for (int hops = 0; p >= 0 && map.points[p].bad && hops < 64; ++hops) p = map.points[p].replaced_by;
      if (p < 0 || map.points[p].bad) continue;
      PoseObservation po;
      po.p_world = map.points[p].p_world;
      po.u = o.u;
      po.v = o.v;
      po.u_right = o.u_right;
      po.inv_sigma2 = pyr.inv_sigma2[o.octave];
      obs.push_back(po);
    }
    if (static_cast<int>(obs.size()) < opt.min_tracked_inliers) continue;
    const Eigen::Isometry3d& T_ref = map.keyframes[r.ref_kf].T_cam_world;
    Eigen::Isometry3d T = r.T_cam_ref * T_ref;
    if (OptimizePose(cam, &obs, &T) < opt.min_tracked_inliers) continue;  // keep the tracked pose
    r.T_cam_ref = T * T_ref.inverse();
  }
}

}  // namespace rs
