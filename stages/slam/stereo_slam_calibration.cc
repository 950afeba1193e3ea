// StereoSlam's disparity self-calibration: the constant disparity offset the keyframes' own motion
// implies (disparity_calibration.h, estimated in Finish over the whole map) is added to every stereo
// measurement of the map before the global BA, which then moves keyframes, frames and points onto the
// corrected depths. KITTI's rectified pairs measure disparities ~0.24 px short (docs/stages/slam.md):
// the estimate from the map alone matches the LiDAR check, and applying it this way recovers the
// accuracy of a correction known from the start.
#include <algorithm>
#include <cmath>
#include <vector>

#include "stages/slam/disparity_calibration.h"
#include "stages/slam/stereo_slam_internal.h"

namespace rs {

namespace {
// An offset is applied only when it is known to 0.03 px and differs from zero by 3 standard errors
// (a rig without offset keeps its measurements untouched).
constexpr double kMaxSigmaPx = 0.03;
constexpr double kMinSignificance = 3;
constexpr int kMinSamples = 300;
// The offset is observable through motion along the optical axis only; the estimator's model lacks
// what dominates otherwise (a nadir view at 60 m over the simulator's road: -5.5 +- 0.22 px for a
// true 0), so most of the path must run along the viewing direction (KITTI: ~1; nadir: ~0).
constexpr double kMinForwardShare = 0.5;

// Median over consecutive keyframes of |t_z| / |t|, t their displacement in the first one's camera frame.
double ForwardShare(const SlamMap& map) {
  std::vector<double> share;
  const Keyframe* prev = nullptr;
  for (const Keyframe& kf : map.keyframes) {
    if (kf.bad) continue;
    if (prev && prev->segment == kf.segment) {
      const Eigen::Vector3d t = prev->T_cam_world * kf.Center();
      if (t.norm() > 0) share.push_back(std::abs(t.z()) / t.norm());
    }
    prev = &kf;
  }
  if (share.empty()) return 0;
  std::nth_element(share.begin(), share.begin() + share.size() / 2, share.end());
  return share[share.size() / 2];
}

}  // namespace

void StereoSlam::Impl::ApplyDisparitySelfCalibration() {
  const double o = stats.disparity_offset_px, sigma = stats.disparity_offset_sigma_px;
  if (stats.disparity_offset_samples < kMinSamples || !(sigma > 0) || sigma > kMaxSigmaPx ||
      std::abs(o) < kMinSignificance * sigma || ForwardShare(map) < kMinForwardShare)
    return;
  for (Keyframe& kf : map.keyframes) AddDisparityOffset(&kf.features, cam, o);
  // The tracked frames' matches that join the global BA (global_refinement.h).
  for (FrameRecord& r : records)
    for (FrameObservation& ob : r.observations) {
      if (ob.u_right < 0) continue;
      const double ur = ob.u_right - o;
      ob.u_right = KeepsStereoMatch(ob.u, ur) ? static_cast<float>(ur) : -1.f;
    }
  stats.disparity_offset_applied_px = o;
}

}  // namespace rs
