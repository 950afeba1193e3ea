// StereoSlam on tracking loss: relocalisation against candidate keyframes and the placement of a lost
// (prior-only) frame by extrapolation pulled towards the flight log. Track starts the new map segment.
#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "stages/slam/stereo_slam_internal.h"

namespace rs {

namespace {

// Acceleration a survey flight is assumed to stay within while tracking is lost: the constant-velocity
// prediction's error grows as 0.5 a t^2 and is weighed against the flight log's position noise.
constexpr double kLostAccelerationM_S2 = 1.0;

}  // namespace

Eigen::Vector3d StereoSlam::Impl::FrameCenter(const FrameRecord& r) const {
  return (r.T_cam_ref * map.keyframes[r.ref_kf].T_cam_world).inverse().translation();
}

// Rigid transform mapping prior-world positions onto the SLAM camera centres (Umeyama, no scale),
// fitted over the frames placed visually; none while their priors span too little (< 5 m and
// < 5 sigma RMS about their mean) to fix the rotation.
std::optional<Eigen::Isometry3d> StereoSlam::Impl::PriorToSlam(double sigma_m) const {
  std::vector<Eigen::Vector3d> src, dst;
  for (const FrameRecord& r : records) {
    if (r.status == FrameStatus::kPriorOnly || !r.p_prior) continue;
    src.push_back(*r.p_prior);
    dst.push_back(FrameCenter(r));
  }
  if (src.size() < 10) return std::nullopt;
  Eigen::Matrix3Xd S(3, src.size()), D(3, src.size());
  for (size_t k = 0; k < src.size(); ++k) {
    S.col(k) = src[k];
    D.col(k) = dst[k];
  }
  const double spread = std::sqrt((S.colwise() - S.rowwise().mean()).squaredNorm() / src.size());
  if (spread < std::max(5.0, 5 * sigma_m)) return std::nullopt;
  return Eigen::Isometry3d(Eigen::umeyama(S, D, false));
}

// A lost frame (neither tracking nor relocalisation placed it), and the frame after one, is
// predicted from the last visually placed frame, moved on by the mean velocity of the second of its
// segment's frames before it (their bundle-adjusted poses: one frame's tracked motion can be several
// centimetres off on a narrow nadir view, which extrapolation would multiply). With a GNSS prior the
// position is then pulled towards the flight log's: the prior's displacement since that frame,
// rotated into the SLAM world (the GNSS bias cancels), weighted against the extrapolation's error
// 0.5 a t^2. The orientation stays the constant-velocity prediction's. Returns the flight log's weight.
double StereoSlam::Impl::PlaceLostFrame(TrackFrame* cur) const {
  const FrameRecord* anchor = nullptr;
  const FrameRecord* early = nullptr;
  for (auto it = records.rbegin(); it != records.rend(); ++it) {
    const bool visual = it->status != FrameStatus::kPriorOnly;
    if (!anchor) {
      if (visual) anchor = early = &*it;
      continue;
    }
    if (!visual || it->segment != anchor->segment || anchor->t_ns - it->t_ns > 1'000'000'000) break;
    early = &*it;
  }
  if (!anchor) return 0;
  Eigen::Isometry3d T_world_cam = cur->T_cam_world.inverse();
  const Eigen::Vector3d c_anchor = FrameCenter(*anchor);
  const double dt = 1e-9 * static_cast<double>(cur->t_ns - anchor->t_ns);
  Eigen::Vector3d p = T_world_cam.translation();
  if (early != anchor)
    p = c_anchor + (c_anchor - FrameCenter(*early)) * (dt / (1e-9 * static_cast<double>(anchor->t_ns - early->t_ns)));
  double w = 0;
  if (cur->prior && cur->prior->has_position && anchor->p_prior) {
    const double sigma = cur->prior->sigma_position_m;
    if (const std::optional<Eigen::Isometry3d> align = PriorToSlam(sigma)) {
      const double var_prediction = std::pow(0.5 * kLostAccelerationM_S2 * dt * dt, 2);
      const double var_gnss = 2 * sigma * sigma;  // two fixes differenced
      w = var_prediction / (var_prediction + var_gnss);
      const Eigen::Vector3d p_gnss =
          c_anchor + align->linear() * (cur->prior->T_world_cam.translation() - *anchor->p_prior);
      p = (1 - w) * p + w * p_gnss;
    }
  }
  T_world_cam.translation() = p;
  cur->T_cam_world = T_world_cam.inverse();
  return w;
}

bool StereoSlam::Impl::Relocalise(TrackFrame* cur) {
  std::vector<int> cand;
  auto add = [&](int k) {
    if (k >= 0 && !map.keyframes[k].bad && std::find(cand.begin(), cand.end(), k) == cand.end()) cand.push_back(k);
  };
  add(ref_kf);
  if (ref_kf >= 0)
    for (int k : map.keyframes[ref_kf].BestCovisible(4)) add(k);
  for (int k = static_cast<int>(map.keyframes.size()) - 1; k >= 0 && cand.size() < 8; --k) add(k);
  if (cur->prior && cur->prior->has_position) {
    for (const Keyframe& kf : map.keyframes) {
      if (cand.size() >= 14) break;
      if (kf.prior && kf.prior->has_position &&
          (kf.prior->T_world_cam.translation() - cur->prior->T_world_cam.translation()).norm() <
              opt.loop_prior_radius_m * 0.5)
        add(kf.id);
    }
  }
  const Eigen::Isometry3d start = cur->T_cam_world;
  for (int k : cand) {
    cur->T_cam_world = start;
    if (RelocaliseAgainst(cur, k)) return true;
  }
  cur->T_cam_world = start;
  cur->Reset(cur->f.size());
  return false;
}

}  // namespace rs
