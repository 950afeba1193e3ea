// StereoSlam tracking: feature search by projection, motion-only optimisation, the constant-velocity
// motion model against the previous frame, descriptor matching + PnP against a keyframe (reference
// keyframe, also used by relocalisation) and local-map tracking.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include <Eigen/Core>  // before OpenCV's Eigen utility header
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "stages/slam/pose_optimizer.h"
#include "stages/slam/stereo_slam_internal.h"

namespace rs {

// ORB-SLAM2 trusts stereo depths below close_depth_baselines and makes at least the 100 nearest
// points per keyframe. A nadir view from altitude has every point beyond that (25 m over a 0.3 m
// baseline is 83 baselines), all at about one depth and so of about one precision: 100 points per
// keyframe cannot follow fast image motion.
// So when fewer than those 100 features are close, the nearest min_close_points count as close. A
// view with a near field (KITTI: hundreds of close points) keeps the plain rule.
double StereoSlam::Impl::CloseDepthLimit(const StereoFeatures& f) const {
  std::vector<float> depth;
  int close = 0;
  for (float d : f.depth_m) {
    if (d > 0) depth.push_back(d);
    close += d > 0 && d <= close_depth_m;
  }
  const size_t n = static_cast<size_t>(opt.min_close_points);
  if (n == 0 || depth.empty() || close >= 100) return close_depth_m;
  if (depth.size() <= n) return std::max<double>(close_depth_m, *std::max_element(depth.begin(), depth.end()));
  std::nth_element(depth.begin(), depth.begin() + (n - 1), depth.end());
  return std::max<double>(close_depth_m, depth[n - 1]);
}

// Best feature of `cur` for a projected point; -1 if none within the limits.
int StereoSlam::Impl::SearchOne(const TrackFrame& cur, const uint8_t* desc, double u, double v, double ur_pred,
                                double radius, int min_level, int max_level, bool ratio_test, int max_hamming) const {
  const std::vector<int> cand = cur.f.FeaturesInArea(u, v, radius, min_level, max_level);
  int best = 256, second = 256, best_i = -1, best_level = -1, second_level = -1;
  for (int i : cand) {
    if (cur.has[i]) continue;
    if (ur_pred >= 0 && cur.f.u_right[i] >= 0 && std::abs(ur_pred - cur.f.u_right[i]) > radius) continue;
    const int d = DescriptorDistance(desc, cur.f.descriptors.ptr<uint8_t>(i));
    if (d < best) {
      second = best;
      second_level = best_level;
      best = d;
      best_i = i;
      best_level = cur.f.keypoints[i].octave;
    } else if (d < second) {
      second = d;
      second_level = cur.f.keypoints[i].octave;
    }
  }
  if (best_i < 0 || best > max_hamming) return -1;
  if (ratio_test && best_level == second_level && best > opt.match_ratio * second) return -1;
  return best_i;
}

std::vector<PoseObservation> StereoSlam::Impl::Observations(const TrackFrame& cur, std::vector<int>* index) const {
  std::vector<PoseObservation> obs;
  index->clear();
  for (size_t i = 0; i < cur.f.size(); ++i) {
    if (!cur.has[i]) continue;
    PoseObservation o;
    o.p_world = cur.mp[i] >= 0 ? map.points[cur.mp[i]].p_world : cur.p_world[i];
    o.u = cur.f.keypoints[i].pt.x;
    o.v = cur.f.keypoints[i].pt.y;
    o.u_right = cur.f.u_right[i];
    o.inv_sigma2 = pyr.inv_sigma2[cur.f.keypoints[i].octave];
    obs.push_back(o);
    index->push_back(static_cast<int>(i));
  }
  return obs;
}

// Optimises cur's pose, drops outlier matches; returns the map-point inliers.
int StereoSlam::Impl::OptimizeAndClean(TrackFrame* cur) {
  std::vector<int> index;
  std::vector<PoseObservation> obs = Observations(*cur, &index);
  cur->all_inliers = 0;
  if (obs.size() < 3) return 0;
  OptimizePose(cam, &obs, &cur->T_cam_world);
  int map_inliers = 0;
  for (size_t k = 0; k < obs.size(); ++k) {
    const int i = index[k];
    if (obs[k].outlier) {
      cur->has[i] = 0;
      cur->mp[i] = -1;
      continue;
    }
    ++cur->all_inliers;
    if (cur->mp[i] >= 0) ++map_inliers;
  }
  return map_inliers;
}

// Refreshes the previous frame after BA moved its reference keyframe, and adds temporary stereo
// points for its unmatched close features (visual odometry between keyframes).
void StereoSlam::Impl::UpdateLastFrame() {
  const FrameRecord& rec = records.back();
  if (rec.ref_kf >= 0) last.T_cam_world = rec.T_cam_ref * map.keyframes[rec.ref_kf].T_cam_world;
  const Eigen::Isometry3d T_world_cam = last.T_cam_world.inverse();
  std::vector<std::pair<float, int>> by_depth;
  for (size_t i = 0; i < last.f.size(); ++i) {
    if (last.mp[i] >= 0 && map.points[last.mp[i]].bad) {
      last.mp[i] = -1;
      last.has[i] = 0;
    }
    if (last.mp[i] < 0) last.has[i] = 0;
    if (last.f.depth_m[i] > 0 && last.mp[i] < 0) by_depth.emplace_back(last.f.depth_m[i], static_cast<int>(i));
  }
  std::sort(by_depth.begin(), by_depth.end());
  int added = 0;
  for (auto& [d, i] : by_depth) {
    if (d > last.close_depth_m && added >= 100) break;
    last.p_world[i] = T_world_cam * Backproject(last.f, i);
    last.has[i] = 1;
    ++added;
  }
}

int StereoSlam::Impl::MatchFromLast(TrackFrame* cur, double radius_factor) {
  cur->Reset(cur->f.size());
  int matches = 0;
  for (size_t i = 0; i < last.f.size(); ++i) {
    if (!last.has[i]) continue;
    const Eigen::Vector3d pw = last.mp[i] >= 0 ? map.points[last.mp[i]].p_world : last.p_world[i];
    const Eigen::Vector3d pc = cur->T_cam_world * pw;
    if (pc.z() <= 0) continue;
    const double u = cam.f_px * pc.x() / pc.z() + cam.cx_px, v = cam.f_px * pc.y() / pc.z() + cam.cy_px;
    if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
    const double ur = u - cam.bf() / pc.z();
    const int level = last.f.keypoints[i].octave;
    const double radius = radius_factor * opt.search_radius_px * pyr.scale[level];
    const uint8_t* desc = last.mp[i] >= 0 ? map.points[last.mp[i]].descriptor.ptr<uint8_t>(0)
                                          : last.f.descriptors.ptr<uint8_t>(static_cast<int>(i));
    const int j =
        SearchOne(*cur, desc, u, v, ur, radius, std::max(0, level - 1), level + 1, false, opt.match_max_hamming);
    if (j < 0) continue;
    cur->mp[j] = last.mp[i] >= 0 ? last.mp[i] : -2;  // -2: temporary point (not in the map)
    cur->p_world[j] = pw;
    cur->has[j] = 1;
    ++matches;
  }
  for (int& m : cur->mp)
    if (m == -2) m = -1;
  return matches;
}

bool StereoSlam::Impl::TrackWithMotionModel(TrackFrame* cur) {
  const Eigen::Isometry3d predicted = cur->T_cam_world;
  int matches = MatchFromLast(cur, 1.0);
  if (matches < 20) {
    cur->T_cam_world = predicted;
    matches = MatchFromLast(cur, 2.0);
  }
  if (matches < 20) return false;
  return OptimizeAndClean(cur) >= 10;
}

// Matches cur against keyframe kf's map points by descriptor, then PnP RANSAC; true with >= 15 inliers.
bool StereoSlam::Impl::RelocaliseAgainst(TrackFrame* cur, int kf_id) {
  const Keyframe& kf = map.keyframes[kf_id];
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  std::vector<std::pair<int, int>> pairs;  // (cur feature, map point)
  std::vector<int> kf_feats;
  for (size_t j = 0; j < kf.points.size(); ++j)
    if (kf.points[j] >= 0 && !map.points[kf.points[j]].bad) kf_feats.push_back(static_cast<int>(j));
  std::vector<int> used(map.points.size(), 0);
  for (size_t i = 0; i < cur->f.size(); ++i) {
    int best = 256, second = 256, best_j = -1;
    const uint8_t* d = cur->f.descriptors.ptr<uint8_t>(static_cast<int>(i));
    for (int j : kf_feats) {
      const int dist = DescriptorDistance(d, kf.features.descriptors.ptr<uint8_t>(j));
      if (dist < best) {
        second = best;
        best = dist;
        best_j = j;
      } else if (dist < second) {
        second = dist;
      }
    }
    if (best_j < 0 || best > 64 || best > 0.75 * second) continue;
    const int p = kf.points[best_j];
    if (used[p]++) continue;
    const Eigen::Vector3d& x = map.points[p].p_world;
    obj.emplace_back(x.x(), x.y(), x.z());
    img.emplace_back(cur->f.keypoints[i].pt.x, cur->f.keypoints[i].pt.y);
    pairs.emplace_back(static_cast<int>(i), p);
  }
  if (pairs.size() < 15) return false;
  cv::Mat K = (cv::Mat_<double>(3, 3) << cam.f_px, 0, cam.cx_px, 0, cam.f_px, cam.cy_px, 0, 0, 1);
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  cv::theRNG().state = opt.ransac_seed;  // solvePnPRansac draws from OpenCV's RNG: fix it
  if (!cv::solvePnPRansac(obj, img, K, cv::noArray(), rvec, tvec, false, 300, 3.0f, 0.99, inliers, cv::SOLVEPNP_EPNP) ||
      inliers.size() < 15)
    return false;
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(R, Re);
  cur->T_cam_world.linear() = Re;
  cur->T_cam_world.translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  cur->Reset(cur->f.size());
  for (int k : inliers) {
    const auto [i, p] = pairs[k];
    cur->mp[i] = p;
    cur->p_world[i] = map.points[p].p_world;
    cur->has[i] = 1;
  }
  return OptimizeAndClean(cur) >= 15;
}

// Descriptor matching against the reference keyframe (no motion prior needed).
bool StereoSlam::Impl::TrackReferenceKeyframe(TrackFrame* cur) {
  const Eigen::Isometry3d start = cur->T_cam_world;
  if (ref_kf >= 0 && RelocaliseAgainst(cur, ref_kf)) return true;
  cur->T_cam_world = start;
  cur->Reset(cur->f.size());
  return false;
}

std::vector<int> StereoSlam::Impl::LocalKeyframes(const TrackFrame& cur) {
  std::map<int, int> counts;
  for (size_t i = 0; i < cur.f.size(); ++i)
    if (cur.mp[i] >= 0)
      for (auto& [k, f] : map.points[cur.mp[i]].observations) ++counts[k];
  std::vector<std::pair<int, int>> order;
  for (auto& [k, c] : counts) order.emplace_back(-c, k);
  std::sort(order.begin(), order.end());
  // No match yet (the frame after a dropout, searched from the prediction): the reference keyframe's.
  if (order.empty() && ref_kf >= 0) order.emplace_back(0, ref_kf);
  std::vector<int> local;
  std::set<int> in;
  for (auto& [c, k] : order) {
    if (static_cast<int>(local.size()) >= opt.local_map_keyframes) break;
    local.push_back(k);
    in.insert(k);
  }
  if (!order.empty()) ref_kf = order.front().second;
  const size_t direct = local.size();
  for (size_t n = 0; n < direct && static_cast<int>(local.size()) < opt.local_map_keyframes; ++n) {
    for (int k : map.keyframes[local[n]].BestCovisible(5)) {
      if (static_cast<int>(local.size()) >= opt.local_map_keyframes) break;
      if (in.insert(k).second) local.push_back(k);
    }
  }
  return local;
}

int StereoSlam::Impl::TrackLocalMap(TrackFrame* cur, double th) {
  const std::vector<int> local = LocalKeyframes(*cur);
  if (point_mark.size() < map.points.size()) point_mark.resize(map.points.size(), -1);
  for (size_t i = 0; i < cur->f.size(); ++i)
    if (cur->mp[i] >= 0) point_mark[cur->mp[i]] = cur->index;
  const Eigen::Isometry3d T_world_cam = cur->T_cam_world.inverse();
  const Eigen::Vector3d center = T_world_cam.translation();
  for (int k : local) {
    for (int p : map.keyframes[k].points) {
      if (p < 0 || point_mark[p] == cur->index) continue;
      point_mark[p] = cur->index;
      MapPoint& mp = map.points[p];
      if (mp.bad) continue;
      const Eigen::Vector3d pc = cur->T_cam_world * mp.p_world;
      if (pc.z() <= 0) continue;
      const double u = cam.f_px * pc.x() / pc.z() + cam.cx_px, v = cam.f_px * pc.y() / pc.z() + cam.cy_px;
      if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
      const Eigen::Vector3d ray = mp.p_world - center;
      const double dist = ray.norm();
      if (dist < 0.8 * mp.min_distance_m || dist > 1.2 * mp.max_distance_m) continue;
      const double view_cos = ray.dot(mp.normal) / dist;
      if (view_cos < 0.5) continue;
      ++mp.visible;
      const int level = pyr.PredictLevel(dist, mp.max_distance_m);
      const double radius = (view_cos > 0.998 ? 2.5 : 4.0) * th * pyr.scale[level];
      const double ur = u - cam.bf() / pc.z();
      const int j = SearchOne(*cur, mp.descriptor.ptr<uint8_t>(0), u, v, ur, radius, std::max(0, level - 1), level,
                              true, opt.match_max_hamming);
      if (j < 0) continue;
      cur->mp[j] = p;
      cur->p_world[j] = mp.p_world;
      cur->has[j] = 1;
    }
  }
  const int inliers = OptimizeAndClean(cur);
  for (size_t i = 0; i < cur->f.size(); ++i)
    if (cur->mp[i] >= 0) ++map.points[cur->mp[i]].found;
  return inliers;
}

}  // namespace rs
