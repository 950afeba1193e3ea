// StereoSlam keyframes and local mapping: the keyframe decision, keyframe insertion with new stereo
// points, and local mapping (recent-point culling, keyframe-to-keyframe triangulation, fusion, local BA).
#include <algorithm>
#include <cmath>
#include <set>
#include <utility>
#include <vector>

#include <Eigen/SVD>

#include "stages/slam/bundle_adjust.h"
#include "stages/slam/epipolar_grid.h"
#include "stages/slam/stereo_slam_internal.h"

namespace rs {

using stereo_slam_internal::Clock;
using stereo_slam_internal::Seconds;

bool StereoSlam::Impl::NeedKeyframe(const TrackFrame& cur, int inliers) const {
  if (ref_kf < 0) return true;
  const int min_obs = map.keyframes.size() <= 2 ? 2 : 3;
  int ref_matches = 0;
  for (int p : map.keyframes[ref_kf].points)
    if (p >= 0 && !map.points[p].bad && static_cast<int>(map.points[p].observations.size()) >= min_obs) ++ref_matches;
  int tracked_close = 0, untracked_close = 0;
  for (size_t i = 0; i < cur.f.size(); ++i) {
    if (cur.f.depth_m[i] <= 0 || cur.f.depth_m[i] > cur.close_depth_m) continue;
    if (cur.mp[i] >= 0)
      ++tracked_close;
    else
      ++untracked_close;
  }
  const bool need_close = tracked_close < 100 && untracked_close > 70;
  const bool gap = cur.index - last_kf_frame >= opt.keyframe_max_gap;
  // Also when the inliers near the loss threshold, whatever the reference keyframe holds: with few
  // multi-keyframe points (KITTI's vegetation) the ratio test alone let tracking die one frame later.
  const bool weak =
      inliers < opt.keyframe_tracked_ratio * ref_matches || need_close || inliers < 3 * opt.min_tracked_inliers;
  return (gap || weak) && inliers > 15;
}

int StereoSlam::Impl::CreateKeyframe(TrackFrame* cur, bool new_segment) {
  Keyframe kf;
  kf.id = static_cast<int>(map.keyframes.size());
  kf.frame_index = cur->index;
  kf.t_ns = cur->t_ns;
  kf.T_cam_world = cur->T_cam_world;
  kf.features = cur->f;
  kf.points.assign(cur->f.size(), -1);
  kf.segment = segment;
  kf.prior = cur->prior;
  map.keyframes.push_back(std::move(kf));
  const int id = map.keyframes.back().id;
  std::vector<int> touched;
  for (size_t i = 0; i < cur->f.size(); ++i) {
    const int p = cur->mp[i];
    if (p < 0 || map.points[p].bad || map.points[p].observations.count(id)) continue;
    map.AddObservation(p, id, static_cast<int>(i));
    touched.push_back(p);
  }
  // New points from stereo: every close one, and at least the 100 nearest; the map's first keyframe
  // takes every stereo feature (ORB-SLAM2's stereo initialisation): until triangulation adds points,
  // its far features are all the next frames can take their rotation from.
  const bool first_of_map = id == 0;
  std::vector<std::pair<float, int>> by_depth;
  for (size_t i = 0; i < cur->f.size(); ++i)
    if (cur->f.depth_m[i] > 0 && map.keyframes[id].points[i] < 0)
      by_depth.emplace_back(cur->f.depth_m[i], static_cast<int>(i));
  std::sort(by_depth.begin(), by_depth.end());
  const Eigen::Isometry3d T_world_cam = cur->T_cam_world.inverse();
  int created = 0;
  for (auto& [d, i] : by_depth) {
    if (!first_of_map && d > cur->close_depth_m && created >= 100) break;
    const int p = map.AddPoint(T_world_cam * Backproject(cur->f, i), id, i);
    map.UpdatePointGeometry(p, pyr);
    recent_points.emplace_back(p, id);
    cur->mp[i] = p;
    cur->p_world[i] = map.points[p].p_world;
    cur->has[i] = 1;
    ++created;
  }
  for (int p : touched) {
    map.UpdatePointDescriptor(p);
    map.UpdatePointGeometry(p, pyr);
  }
  map.UpdateCovisibility(id);
  ref_kf = id;
  last_kf_frame = cur->index;
  if (!new_segment) LocalMapping(id);
  return id;
}

// New points from matches between keyframe kf and its best covisible keyframes (ORB-SLAM2's
// CreateNewMapPoints): features without a map point in both, descriptor distance <= 50, within
// the epipolar band (chi2 3.84 at the candidate's level sigma), then linear triangulation with
// positive depth, enough parallax (else the stereo depth, if larger parallax), reprojection chi2 in
// both keyframes and consistent scale. Gives far points (rotation) and multi-keyframe points.
int StereoSlam::Impl::CreateNewMapPoints(int kf) {
  Keyframe& k1 = map.keyframes[kf];
  const Eigen::Isometry3d T1 = k1.T_cam_world;
  const Eigen::Vector3d c1 = k1.Center();
  const Eigen::Matrix3d K = (Eigen::Matrix3d() << cam.f_px, 0, cam.cx_px, 0, cam.f_px, cam.cy_px, 0, 0, 1).finished();
  const Eigen::Matrix3d Kinv = K.inverse();
  const double ratio_factor = 1.5 * (pyr.levels() > 1 ? pyr.scale[1] : 1.0);
  std::vector<int> free1;
  for (size_t i = 0; i < k1.features.size(); ++i)
    if (k1.points[i] < 0) free1.push_back(static_cast<int>(i));
  int created = 0;
  for (int n : k1.BestCovisible(opt.triangulation_neighbours)) {
    Keyframe& k2 = map.keyframes[n];
    if (k2.bad || k2.segment != k1.segment) continue;
    const Eigen::Vector3d c2 = k2.Center();
    if ((c2 - c1).norm() < cam.baseline_m) continue;  // the stereo pair already has this baseline
    const Eigen::Isometry3d T21 = k2.T_cam_world * T1.inverse();
    const Eigen::Matrix3d R21 = T21.linear();
    const Eigen::Vector3d t21 = T21.translation();
    Eigen::Matrix3d tx;
    tx << 0, -t21.z(), t21.y(), t21.z(), 0, -t21.x(), -t21.y(), t21.x(), 0;
    const Eigen::Matrix3d F21 = Kinv.transpose() * tx * R21 * Kinv;  // x2^T F21 x1 = 0
    // Unmatched features of k2 in a grid of cells per pyramid level (a match is searched on levels
    // +-1 only): only the cells the epipolar band crosses are scanned, not every feature of k2. The
    // pick does not depend on the scan order.
    EpipolarGrid grid2(cam.width, cam.height, pyr.levels());
    for (size_t j = 0; j < k2.features.size(); ++j)
      if (k2.points[j] < 0) grid2.Add(k2.features.keypoints[j], static_cast<int>(j));
    std::vector<int> taken2(k2.features.size(), 0);
    std::vector<int> cells;
    for (int i : free1) {
      if (k1.points[i] >= 0) continue;
      const cv::KeyPoint& kp1 = k1.features.keypoints[i];
      const Eigen::Vector3d l = F21 * Eigen::Vector3d(kp1.pt.x, kp1.pt.y, 1);
      const double ln = l.x() * l.x() + l.y() * l.y();
      if (ln < 1e-12) continue;
      const uint8_t* d1 = k1.features.descriptors.ptr<uint8_t>(i);
      const int min_level = std::max(0, kp1.octave - 1), max_level = std::min(pyr.levels() - 1, kp1.octave + 1);
      // Widest band of the levels searched: |l . x| / |l_xy| < sqrt(3.84) sigma.
      grid2.CellsAlongLine(l.x(), l.y(), l.z(), std::sqrt(3.84 * pyr.sigma2[max_level]), &cells);
      int best = 51, best_j = -1;  // smallest distance, ties to the lowest index
      for (int level = min_level; level <= max_level; ++level) {
        const double band = 3.84 * pyr.sigma2[level] * ln;
        for (int cell : cells) {
          for (const EpipolarGrid::Entry& c : grid2.cell(level, cell)) {
            const double num = l.x() * c.x + l.y() * c.y + l.z();
            if (num * num >= band) continue;
            const int j = c.j;
            if (taken2[j]) continue;
            const int d = DescriptorDistance(d1, k2.features.descriptors.ptr<uint8_t>(j));
            if (d < best || (d == best && j < best_j)) {
              best = d;
              best_j = j;
            }
          }
        }
      }
      if (best_j < 0) continue;
      const cv::KeyPoint& kp2 = k2.features.keypoints[best_j];
      const Eigen::Vector3d r1 = Kinv * Eigen::Vector3d(kp1.pt.x, kp1.pt.y, 1);
      const Eigen::Vector3d r2 = Kinv * Eigen::Vector3d(kp2.pt.x, kp2.pt.y, 1);
      const Eigen::Vector3d ray1 = T1.linear().transpose() * r1, ray2 = k2.T_cam_world.linear().transpose() * r2;
      const double cos_rays = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
      const bool stereo1 = k1.features.depth_m[i] > 0, stereo2 = k2.features.depth_m[best_j] > 0;
      const double cos_s1 = stereo1 ? std::cos(2 * std::atan2(cam.baseline_m / 2, k1.features.depth_m[i])) : 2;
      const double cos_s2 = stereo2 ? std::cos(2 * std::atan2(cam.baseline_m / 2, k2.features.depth_m[best_j])) : 2;
      const double cos_stereo = std::min(cos_s1, cos_s2);
      Eigen::Vector3d x;
      if (cos_rays < cos_stereo && cos_rays > 0 && (stereo1 || stereo2 || cos_rays < 0.9998)) {
        // Linear triangulation (DLT) in world coordinates.
        Eigen::Matrix<double, 3, 4> P1 = T1.matrix().topRows<3>(), P2 = k2.T_cam_world.matrix().topRows<3>();
        Eigen::Matrix4d A;
        A.row(0) = r1.x() * P1.row(2) - P1.row(0);
        A.row(1) = r1.y() * P1.row(2) - P1.row(1);
        A.row(2) = r2.x() * P2.row(2) - P2.row(0);
        A.row(3) = r2.y() * P2.row(2) - P2.row(1);
        const Eigen::Vector4d h = Eigen::JacobiSVD<Eigen::Matrix4d>(A, Eigen::ComputeFullV).matrixV().col(3);
        if (std::abs(h(3)) < 1e-12) continue;
        x = h.head<3>() / h(3);
      } else if (stereo1 && cos_s1 < cos_s2) {
        x = T1.inverse() * Backproject(k1.features, i);
      } else if (stereo2 && cos_s2 < cos_s1) {
        x = k2.T_cam_world.inverse() * Backproject(k2.features, best_j);
      } else {
        continue;  // no parallax
      }
      if (!x.allFinite()) continue;
      bool ok = true;
      for (int side = 0; side < 2 && ok; ++side) {
        const Keyframe& kk = side == 0 ? k1 : k2;
        const int f = side == 0 ? i : best_j;
        const Eigen::Vector3d pc = kk.T_cam_world * x;
        if (pc.z() <= 0) {
          ok = false;
          break;
        }
        const cv::KeyPoint& kp = kk.features.keypoints[f];
        double e2 = std::pow(cam.f_px * pc.x() / pc.z() + cam.cx_px - kp.pt.x, 2) +
                    std::pow(cam.f_px * pc.y() / pc.z() + cam.cy_px - kp.pt.y, 2);
        const bool st = kk.features.u_right[f] >= 0;
        if (st) e2 += std::pow(cam.f_px * (pc.x() - cam.baseline_m) / pc.z() + cam.cx_px - kk.features.u_right[f], 2);
        if (e2 * pyr.inv_sigma2[kp.octave] > (st ? kChi2Stereo : kChi2Mono)) ok = false;
      }
      if (!ok) continue;
      const double dist1 = (x - c1).norm(), dist2 = (x - c2).norm();
      if (dist1 <= 0 || dist2 <= 0) continue;
      const double ratio_dist = dist2 / dist1;
      const double ratio_octave = pyr.scale[kp1.octave] / pyr.scale[kp2.octave];
      if (ratio_dist * ratio_factor < ratio_octave || ratio_dist > ratio_octave * ratio_factor) continue;
      const int p = map.AddPoint(x, kf, i);
      map.AddObservation(p, n, best_j);
      map.UpdatePointDescriptor(p);
      map.UpdatePointGeometry(p, pyr);
      recent_points.emplace_back(p, kf);
      taken2[best_j] = 1;
      ++created;
    }
  }
  return created;
}

void StereoSlam::Impl::CullRecentPoints(int kf) {
  std::vector<std::pair<int, int>> keep;
  for (auto [p, created] : recent_points) {
    MapPoint& mp = map.points[p];
    if (mp.bad) continue;
    if (static_cast<double>(mp.found) / mp.visible < 0.25) {
      map.SetBad(p);
    } else if (kf - created >= 2 && mp.observations.size() <= 1) {
      map.SetBad(p);
    } else if (kf - created < 3) {
      keep.emplace_back(p, created);
    }
  }
  recent_points.swap(keep);
}

// Projects points into keyframe `target`; merges with or adds to the feature found there.
void StereoSlam::Impl::FuseInto(int target, const std::vector<int>& pts) {
  Keyframe& kf = map.keyframes[target];
  const Eigen::Vector3d center = kf.Center();
  for (int p : pts) {
    if (p < 0 || map.points[p].bad || map.points[p].observations.count(target)) continue;
    const MapPoint& mp = map.points[p];
    const Eigen::Vector3d pc = kf.T_cam_world * mp.p_world;
    if (pc.z() <= 0) continue;
    const double u = cam.f_px * pc.x() / pc.z() + cam.cx_px, v = cam.f_px * pc.y() / pc.z() + cam.cy_px;
    if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
    const double ur = u - cam.bf() / pc.z();
    const Eigen::Vector3d ray = mp.p_world - center;
    const double dist = ray.norm();
    if (dist < 0.8 * mp.min_distance_m || dist > 1.2 * mp.max_distance_m) continue;
    if (ray.dot(mp.normal) < 0.5 * dist) continue;
    const int level = pyr.PredictLevel(dist, mp.max_distance_m);
    const double radius = 3.0 * pyr.scale[level];
    int best = 256, best_i = -1;
    for (int i : kf.features.FeaturesInArea(u, v, radius, std::max(0, level - 1), level + 1)) {
      const cv::KeyPoint& kp = kf.features.keypoints[i];
      double e2 = std::pow(kp.pt.x - u, 2) + std::pow(kp.pt.y - v, 2);
      const bool stereo = kf.features.u_right[i] >= 0;
      if (stereo) e2 += std::pow(kf.features.u_right[i] - ur, 2);
      if (e2 * pyr.inv_sigma2[kp.octave] > (stereo ? kChi2Stereo : kChi2Mono)) continue;
      const int d = DescriptorDistance(mp.descriptor.ptr<uint8_t>(0), kf.features.descriptors.ptr<uint8_t>(i));
      if (d < best) {
        best = d;
        best_i = i;
      }
    }
    if (best_i < 0 || best > 50) continue;
    const int existing = kf.points[best_i];
    if (existing >= 0 && !map.points[existing].bad) {
      if (map.points[existing].observations.size() >= mp.observations.size())
        map.Replace(p, existing);
      else
        map.Replace(existing, p);
    } else {
      map.AddObservation(p, target, best_i);
    }
  }
}

void StereoSlam::Impl::LocalMapping(int kf) {
  const auto t0 = Clock::now();
  CullRecentPoints(kf);
  if (opt.triangulation_neighbours > 0) CreateNewMapPoints(kf);
  std::vector<int> neighbours = map.keyframes[kf].BestCovisible(10);
  {
    std::set<int> in(neighbours.begin(), neighbours.end());
    const size_t direct = neighbours.size();
    for (size_t n = 0; n < direct; ++n)
      for (int k : map.keyframes[neighbours[n]].BestCovisible(5))
        if (k != kf && in.insert(k).second) neighbours.push_back(k);
  }
  for (int n : neighbours) FuseInto(n, map.keyframes[kf].points);
  std::vector<int> theirs;
  {
    std::set<int> seen;
    for (int n : neighbours)
      for (int p : map.keyframes[n].points)
        if (p >= 0 && !map.points[p].bad && seen.insert(p).second) theirs.push_back(p);
  }
  FuseInto(kf, theirs);
  for (int p : map.keyframes[kf].points) {
    if (p < 0 || map.points[p].bad) continue;
    map.UpdatePointDescriptor(p);
    map.UpdatePointGeometry(p, pyr);
  }
  map.UpdateCovisibility(kf);
  std::vector<int> window = {kf};
  for (int k : map.keyframes[kf].BestCovisible(opt.local_ba_keyframes - 1))
    if (map.keyframes[k].segment == map.keyframes[kf].segment) window.push_back(k);
  BundleAdjust(&map, window, cam, pyr, opt.local_ba_iterations, true, {}, opt.local_ba_fixed_size);
  map.UpdateCovisibility(kf);
  stats.local_mapping_s += Seconds(t0);
}

}  // namespace rs
