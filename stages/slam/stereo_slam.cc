#include "stages/slam/stereo_slam.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include <fmt/format.h>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "stages/slam/bundle_adjust.h"
#include "stages/slam/disparity_calibration.h"
#include "stages/slam/loop_closing.h"
#include "stages/slam/pose_optimizer.h"

namespace rs {

const char* ToString(FrameStatus status) {
  switch (status) {
    case FrameStatus::kTracked: return "tracked";
    case FrameStatus::kRelocalised: return "relocalised";
    case FrameStatus::kPriorOnly: return "prior-only";
  }
  return "?";
}

std::string SlamStatistics::BriefReport() const {
  return fmt::format("{} frames ({} tracked, {} relocalised, {} prior-only of which {} GNSS-positioned), {} keyframes, "
                     "{} points, {} segments, {} loops closed ({} rejected of {} candidates)",
                     frames, tracked, relocalised, prior_only, gnss_positioned, keyframes, map_points, segments, loops_closed,
                     loops_rejected, loop_candidates);
}

namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a) { return std::chrono::duration<double>(Clock::now() - a).count(); }

// The frame being tracked (and, after Track, the previous frame).
struct TrackFrame {
  int index = -1;
  int64_t t_ns = 0;
  StereoFeatures f;
  std::vector<int> mp;                 // map point per feature, -1 none
  std::vector<Eigen::Vector3d> p_world;  // 3-D point per matched feature (map point or temporary stereo point)
  std::vector<char> has;               // p_world valid
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  std::optional<PosePrior> prior;
  double close_depth_m = 0;            // stereo points nearer than this are "close" (CloseDepthLimit)
  void Reset(size_t n) {
    mp.assign(n, -1);
    p_world.assign(n, Eigen::Vector3d::Zero());
    has.assign(n, 0);
  }
};

struct FrameRecord {
  int64_t t_ns = 0;
  int ref_kf = -1;
  Eigen::Isometry3d T_cam_ref = Eigen::Isometry3d::Identity();
  FrameStatus status = FrameStatus::kTracked;
  int segment = 0;
  std::optional<Eigen::Vector3d> p_prior;  // the frame's GNSS position (prior world), if any
};

// Acceleration a survey flight is assumed to stay within while tracking is lost: the constant-velocity
// prediction's error grows as 0.5 a t^2 and is weighed against the flight log's position noise.
constexpr double kLostAccelerationM_S2 = 1.0;

}  // namespace

struct StereoSlam::Impl {
  SlamOptions opt;
  StereoCamera cam;
  ScalePyramid pyr;
  SlamMap map;
  double close_depth_m = 0;  // close_depth_baselines x baseline (a frame's own limit: CloseDepthLimit)
  std::vector<FrameRecord> records;
  TrackFrame last;
  bool has_last = false;
  Eigen::Isometry3d velocity = Eigen::Isometry3d::Identity();
  bool has_velocity = false;
  int ref_kf = -1;
  int last_kf_frame = -1;
  int segment = 0;
  std::vector<int> point_mark;  // last frame index a point was put in the local map
  std::vector<std::pair<int, int>> recent_points;  // (point, keyframe that created it)
  SlamStatistics stats;
  bool finished = false;

  // ORB-SLAM2 trusts stereo depths below close_depth_baselines and makes at least the 100 nearest
  // points per keyframe. A nadir view from altitude has every point beyond that (25 m over a 0.3 m
  // baseline is 83 baselines), all at about one depth and so of about one precision: 100 points per
  // keyframe could not follow 24 px of image motion per frame (drone-high lost tracking four times).
  // So when fewer than those 100 features are close, the nearest min_close_points count as close. A
  // view with a near field (KITTI: hundreds of close points) keeps the plain rule.
  double CloseDepthLimit(const StereoFeatures& f) const {
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

  Eigen::Vector3d Backproject(const StereoFeatures& f, int i) const {
    const double z = f.depth_m[i];
    return {(f.keypoints[i].pt.x - cam.cx) * z / cam.fx, (f.keypoints[i].pt.y - cam.cy) * z / cam.fy, z};
  }

  // Best feature of `cur` for a projected point; -1 if none within the limits.
  int SearchOne(const TrackFrame& cur, const uint8_t* desc, double u, double v, double ur_pred, double radius,
                int min_level, int max_level, bool ratio_test, int max_hamming) const {
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

  std::vector<PoseObservation> Observations(const TrackFrame& cur, std::vector<int>* index) const {
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
  int OptimizeAndClean(TrackFrame* cur) {
    std::vector<int> index;
    std::vector<PoseObservation> obs = Observations(*cur, &index);
    if (obs.size() < 3) return 0;
    OptimizePose(cam, &obs, &cur->T_cam_world);
    int map_inliers = 0;
    for (size_t k = 0; k < obs.size(); ++k) {
      const int i = index[k];
      if (obs[k].outlier) {
        cur->has[i] = 0;
        cur->mp[i] = -1;
      } else if (cur->mp[i] >= 0) {
        ++map_inliers;
      }
    }
    return map_inliers;
  }

  // Refreshes the previous frame after BA moved its reference keyframe, and adds temporary stereo
  // points for its unmatched close features (visual odometry between keyframes).
  void UpdateLastFrame() {
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

  int MatchFromLast(TrackFrame* cur, double radius_factor) {
    cur->Reset(cur->f.size());
    int matches = 0;
    for (size_t i = 0; i < last.f.size(); ++i) {
      if (!last.has[i]) continue;
      const Eigen::Vector3d pw = last.mp[i] >= 0 ? map.points[last.mp[i]].p_world : last.p_world[i];
      const Eigen::Vector3d pc = cur->T_cam_world * pw;
      if (pc.z() <= 0) continue;
      const double u = cam.fx * pc.x() / pc.z() + cam.cx, v = cam.fy * pc.y() / pc.z() + cam.cy;
      if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
      const double ur = u - cam.bf() / pc.z();
      const int level = last.f.keypoints[i].octave;
      const double radius = radius_factor * opt.search_radius_px * pyr.scale[level];
      const uint8_t* desc = last.mp[i] >= 0 ? map.points[last.mp[i]].descriptor.ptr<uint8_t>(0)
                                            : last.f.descriptors.ptr<uint8_t>(static_cast<int>(i));
      const int j = SearchOne(*cur, desc, u, v, ur, radius, std::max(0, level - 1), level + 1, false,
                              opt.match_max_hamming);
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

  bool TrackWithMotionModel(TrackFrame* cur) {
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
  bool RelocaliseAgainst(TrackFrame* cur, int kf_id) {
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
    cv::Mat K = (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    cv::theRNG().state = opt.ransac_seed;  // solvePnPRansac draws from OpenCV's RNG: fix it
    if (!cv::solvePnPRansac(obj, img, K, cv::noArray(), rvec, tvec, false, 300, 3.0f, 0.99, inliers,
                            cv::SOLVEPNP_EPNP) ||
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
  bool TrackReferenceKeyframe(TrackFrame* cur) {
    const Eigen::Isometry3d start = cur->T_cam_world;
    if (ref_kf >= 0 && RelocaliseAgainst(cur, ref_kf)) return true;
    cur->T_cam_world = start;
    cur->Reset(cur->f.size());
    return false;
  }

  Eigen::Vector3d FrameCenter(const FrameRecord& r) const {
    return (r.T_cam_ref * map.keyframes[r.ref_kf].T_cam_world).inverse().translation();
  }

  // Rigid transform mapping prior-world positions onto the SLAM camera centres (Umeyama, no scale),
  // fitted over the frames placed visually; none while their priors span too little (< 5 m and
  // < 5 sigma RMS about their mean) to fix the rotation.
  std::optional<Eigen::Isometry3d> PriorToSlam(double sigma_m) const {
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
  double PlaceLostFrame(TrackFrame* cur) const {
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
        const Eigen::Vector3d p_gnss = c_anchor + align->linear() * (cur->prior->T_world_cam.translation() - *anchor->p_prior);
        p = (1 - w) * p + w * p_gnss;
      }
    }
    T_world_cam.translation() = p;
    cur->T_cam_world = T_world_cam.inverse();
    return w;
  }

  bool Relocalise(TrackFrame* cur) {
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

  std::vector<int> LocalKeyframes(const TrackFrame& cur) {
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

  int TrackLocalMap(TrackFrame* cur, double th) {
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
        const double u = cam.fx * pc.x() / pc.z() + cam.cx, v = cam.fy * pc.y() / pc.z() + cam.cy;
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

  bool NeedKeyframe(const TrackFrame& cur, int inliers) const {
    if (ref_kf < 0) return true;
    const int min_obs = map.keyframes.size() <= 2 ? 2 : 3;
    int ref_matches = 0;
    for (int p : map.keyframes[ref_kf].points)
      if (p >= 0 && !map.points[p].bad && static_cast<int>(map.points[p].observations.size()) >= min_obs) ++ref_matches;
    int tracked_close = 0, untracked_close = 0;
    for (size_t i = 0; i < cur.f.size(); ++i) {
      if (cur.f.depth_m[i] <= 0 || cur.f.depth_m[i] > cur.close_depth_m) continue;
      if (cur.mp[i] >= 0) ++tracked_close; else ++untracked_close;
    }
    const bool need_close = tracked_close < 100 && untracked_close > 70;
    const bool gap = cur.index - last_kf_frame >= opt.keyframe_max_gap;
    // Also when the inliers near the loss threshold, whatever the reference keyframe holds: with few
    // multi-keyframe points (KITTI's vegetation) the ratio test alone let tracking die one frame later.
    const bool weak = inliers < opt.keyframe_tracked_ratio * ref_matches || need_close ||
                      inliers < 3 * opt.min_tracked_inliers;
    return (gap || weak) && inliers > 15;
  }

  int CreateKeyframe(TrackFrame* cur, bool new_segment) {
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
    // New points from stereo: every close one, and at least the 100 nearest.
    std::vector<std::pair<float, int>> by_depth;
    for (size_t i = 0; i < cur->f.size(); ++i)
      if (cur->f.depth_m[i] > 0 && map.keyframes[id].points[i] < 0) by_depth.emplace_back(cur->f.depth_m[i], static_cast<int>(i));
    std::sort(by_depth.begin(), by_depth.end());
    const Eigen::Isometry3d T_world_cam = cur->T_cam_world.inverse();
    int created = 0;
    for (auto& [d, i] : by_depth) {
      if (d > cur->close_depth_m && created >= 100) break;
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
  int CreateNewMapPoints(int kf) {
    Keyframe& k1 = map.keyframes[kf];
    const Eigen::Isometry3d T1 = k1.T_cam_world;
    const Eigen::Vector3d c1 = k1.Center();
    const Eigen::Matrix3d K = (Eigen::Matrix3d() << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1).finished();
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
      // Unmatched features of k2 by pyramid level (a match is searched on levels +-1 only), their
      // positions packed beside the index: the epipolar band test below scans them all.
      struct Free {
        float x, y;
        int j;
      };
      std::vector<std::vector<Free>> free2(pyr.levels());
      for (size_t j = 0; j < k2.features.size(); ++j)
        if (k2.points[j] < 0) {
          const cv::Point2f& pt = k2.features.keypoints[j].pt;
          free2[k2.features.keypoints[j].octave].push_back({pt.x, pt.y, static_cast<int>(j)});
        }
      std::vector<int> taken2(k2.features.size(), 0);
      for (int i : free1) {
        if (k1.points[i] >= 0) continue;
        const cv::KeyPoint& kp1 = k1.features.keypoints[i];
        const Eigen::Vector3d l = F21 * Eigen::Vector3d(kp1.pt.x, kp1.pt.y, 1);
        const double ln = l.x() * l.x() + l.y() * l.y();
        if (ln < 1e-12) continue;
        const uint8_t* d1 = k1.features.descriptors.ptr<uint8_t>(i);
        int best = 51, best_j = -1;  // smallest distance, ties to the lowest index
        for (int level = std::max(0, kp1.octave - 1); level <= std::min(pyr.levels() - 1, kp1.octave + 1); ++level) {
          const double band = 3.84 * pyr.sigma2[level] * ln;
          for (const Free& c : free2[level]) {
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
          if (pc.z() <= 0) { ok = false; break; }
          const cv::KeyPoint& kp = kk.features.keypoints[f];
          double e2 = std::pow(cam.fx * pc.x() / pc.z() + cam.cx - kp.pt.x, 2) +
                      std::pow(cam.fy * pc.y() / pc.z() + cam.cy - kp.pt.y, 2);
          const bool st = kk.features.u_right[f] >= 0;
          if (st) e2 += std::pow(cam.fx * (pc.x() - cam.baseline_m) / pc.z() + cam.cx - kk.features.u_right[f], 2);
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

  void CullRecentPoints(int kf) {
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
  void FuseInto(int target, const std::vector<int>& pts) {
    Keyframe& kf = map.keyframes[target];
    const Eigen::Vector3d center = kf.Center();
    for (int p : pts) {
      if (p < 0 || map.points[p].bad || map.points[p].observations.count(target)) continue;
      const MapPoint& mp = map.points[p];
      const Eigen::Vector3d pc = kf.T_cam_world * mp.p_world;
      if (pc.z() <= 0) continue;
      const double u = cam.fx * pc.x() / pc.z() + cam.cx, v = cam.fy * pc.y() / pc.z() + cam.cy;
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
        if (map.points[existing].observations.size() >= mp.observations.size()) map.Replace(p, existing);
        else map.Replace(existing, p);
      } else {
        map.AddObservation(p, target, best_i);
      }
    }
  }

  // Diagnostic only (SlamStatistics): the disparity offset the keyframes' own motion implies
  // (disparity_calibration.h), over the tracked map before loop closing. Not applied: on KITTI it
  // matches the LiDAR check at the end of the clip but scatters beyond its error over shorter windows.
  void EstimateDisparityOffsetOfMap() {
    std::vector<int> kfs;
    for (const Keyframe& kf : map.keyframes)
      if (!kf.bad) kfs.push_back(kf.id);
    int pairs = 0;
    const std::vector<DisparityPairSample> samples = CollectDisparitySamples(map, cam, kfs, &pairs);
    const DisparityOffsetEstimate e = EstimateDisparityOffset(samples, pairs, cam.bf());
    stats.disparity_offset_px = e.offset_px;
    stats.disparity_offset_sigma_px = e.sigma_px;
    stats.disparity_offset_samples = e.samples;
  }

  void LocalMapping(int kf) {
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
    BundleAdjust(&map, window, cam, pyr, opt.local_ba_iterations, true);
    map.UpdateCovisibility(kf);
    stats.local_mapping_s += Seconds(t0);
  }

  FrameResult Track(int64_t t_ns, const cv::Mat& left, const cv::Mat& right, const std::optional<PosePrior>& prior) {
    if (finished) throw std::invalid_argument("StereoSlam::Track called after Finish");
    if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.cols != cam.width || left.rows != cam.height ||
        right.size() != left.size())
      throw std::invalid_argument(fmt::format("StereoSlam::Track: expected two 8-bit grey {}x{} images, got {}x{} and {}x{}",
                                              cam.width, cam.height, left.cols, left.rows, right.cols, right.rows));
    const auto t0 = Clock::now();
    StereoFeatures f = ExtractStereoFeatures(left, right, cam, opt, pyr);
    stats.track_s += Seconds(t0);
    return Track(t_ns, std::move(f), prior);
  }

  FrameResult Track(int64_t t_ns, StereoFeatures features, const std::optional<PosePrior>& prior) {
    if (finished) throw std::invalid_argument("StereoSlam::Track called after Finish");
    if (!records.empty() && t_ns <= records.back().t_ns)
      throw std::invalid_argument(fmt::format("StereoSlam::Track: time {} ns does not follow {} ns", t_ns, records.back().t_ns));
    const auto t0 = Clock::now();
    TrackFrame cur;
    cur.index = static_cast<int>(records.size());
    cur.t_ns = t_ns;
    cur.prior = prior;
    cur.f = std::move(features);
    if (cur.f.grid.empty()) cur.f.BuildGrid(cam.width, cam.height);
    cur.close_depth_m = CloseDepthLimit(cur.f);
    cur.Reset(cur.f.size());
    FrameResult result;
    result.index = cur.index;
    result.t_ns = t_ns;
    result.features = static_cast<int>(cur.f.size());
    for (float d : cur.f.depth_m) result.stereo_features += d > 0;

    FrameStatus status = FrameStatus::kTracked;
    if (map.keyframes.empty()) {
      CreateKeyframe(&cur, true);
      result.keyframe = true;
    } else {
      UpdateLastFrame();
      // Prediction: constant velocity; without one, the prior's relative motion; else the last pose.
      bool has_motion = true;
      if (has_velocity) {
        cur.T_cam_world = velocity * last.T_cam_world;
      } else if (prior && last.prior && prior->has_position && prior->has_attitude && last.prior->has_attitude) {
        cur.T_cam_world = (last.prior->T_world_cam.inverse() * prior->T_world_cam).inverse() * last.T_cam_world;
      } else {
        cur.T_cam_world = last.T_cam_world;
        has_motion = false;
      }
      Eigen::Isometry3d predicted = cur.T_cam_world;
      // After a lost frame: extrapolate the last visually placed frames (and the flight log) instead.
      if (records.back().status == FrameStatus::kPriorOnly) {
        PlaceLostFrame(&cur);
        predicted = cur.T_cam_world;
      }
      bool ok = false;
      if (records.back().status == FrameStatus::kPriorOnly && has_velocity) {
        // After a dropout (frames placed by prediction) the previous frame has no points to match, and
        // descriptor matching against the reference keyframe over a partial overlap of a narrow nadir
        // view locked 0.5 m off along track in a test: search the reference keyframe's local map from
        // the extrapolation (good to centimetres over a few frames) in a wide window first.
        ok = TrackLocalMap(&cur, 3.0) >= opt.min_tracked_inliers;
        if (!ok) {
          cur.T_cam_world = predicted;
          cur.Reset(cur.f.size());
        }
      }
      // Without a motion prediction a projection search would lock onto wrong neighbours of a
      // fast-moving scene (KITTI moves 1.2 m per frame): match descriptors against the reference
      // keyframe first.
      if (!ok && !has_motion) {
        ok = TrackReferenceKeyframe(&cur);
        if (!ok) cur.T_cam_world = predicted;
      }
      if (!ok) ok = TrackWithMotionModel(&cur);
      if (!ok) {
        cur.T_cam_world = predicted;
        ok = TrackReferenceKeyframe(&cur);
      }
      if (!ok) {
        cur.T_cam_world = predicted;
        ok = Relocalise(&cur);
        if (ok) status = FrameStatus::kRelocalised;
      }
      int inliers = 0;
      if (ok) {
        inliers = TrackLocalMap(&cur, status == FrameStatus::kRelocalised ? 3.0 : 1.0);
        ok = inliers >= opt.min_tracked_inliers;
      }
      if (!ok && status == FrameStatus::kTracked) {
        cur.T_cam_world = predicted;
        cur.Reset(cur.f.size());
        if (Relocalise(&cur)) {
          status = FrameStatus::kRelocalised;
          inliers = TrackLocalMap(&cur, 3.0);
          ok = inliers >= opt.min_tracked_inliers;
        }
      }
      if (ok) {
        result.inliers = inliers;
        // Relocalised into another map segment (an older map re-found after a loss): continue in it.
        segment = map.keyframes[ref_kf].segment;
        if (NeedKeyframe(cur, inliers)) {
          CreateKeyframe(&cur, false);
          result.keyframe = true;
        }
      } else {
        // Lost: the prediction, seeded by the flight log (PlaceLostFrame), and a new map segment from
        // this frame's stereo points; Finish() links the segments (sequential pose-graph edge, loops)
        // and optimises them together. A frame with too few points to track against (blank, blurred)
        // seeds none: the next frame tries the old map again.
        status = FrameStatus::kPriorOnly;
        cur.T_cam_world = predicted;
        cur.Reset(cur.f.size());
        result.gnss_weight = PlaceLostFrame(&cur);
        if (result.stereo_features >= 3 * opt.min_tracked_inliers) {
          ++segment;
          ++stats.segments;
          CreateKeyframe(&cur, true);
          result.keyframe = true;
        }
      }
      // The velocity only from two visually placed frames of one segment (a predicted pose or a jump
      // between segments is no motion).
      if (ok && records.back().status != FrameStatus::kPriorOnly && records.back().segment == segment) {
        velocity = cur.T_cam_world * last.T_cam_world.inverse();
        has_velocity = true;
      }
    }
    FrameRecord rec;
    rec.t_ns = t_ns;
    rec.ref_kf = ref_kf;
    rec.T_cam_ref = cur.T_cam_world * map.keyframes[ref_kf].T_cam_world.inverse();
    rec.status = status;
    rec.segment = segment;
    if (prior && prior->has_position) rec.p_prior = prior->T_world_cam.translation();
    records.push_back(rec);
    ++stats.frames;
    if (status == FrameStatus::kTracked) ++stats.tracked;
    if (status == FrameStatus::kRelocalised) ++stats.relocalised;
    if (status == FrameStatus::kPriorOnly) ++stats.prior_only;
    if (status == FrameStatus::kPriorOnly && result.gnss_weight >= 0.5) ++stats.gnss_positioned;
    result.status = status;
    result.segment = segment;
    result.T_world_cam = cur.T_cam_world.inverse();
    last = std::move(cur);
    has_last = true;
    stats.track_s += Seconds(t0);
    return result;
  }

  SlamResult Finish() {
    if (finished) throw std::invalid_argument("StereoSlam::Finish called twice");
    finished = true;
    const auto t0 = Clock::now();
    SlamResult out;
    EstimateDisparityOffsetOfMap();
    if (map.keyframes.size() >= 2) {
      std::vector<LoopClosure> loops;
      if (opt.loop_closure) loops = DetectAndCloseLoops(&map, cam, pyr, opt, &stats);
      out.loops = loops;
      if (opt.global_ba_iterations > 0) {
        std::vector<int> all;
        for (const Keyframe& kf : map.keyframes)
          if (kf.id > 0 && !kf.bad) all.push_back(kf.id);
        BundleAdjust(&map, all, cam, pyr, opt.global_ba_iterations, true, {0});
      }
    }
    out.frames.source = "StereoSlam";
    for (size_t i = 0; i < records.size(); ++i) {
      const FrameRecord& r = records[i];
      StampedPose sp;
      sp.t_ns = r.t_ns;
      sp.T_world_frame = (r.T_cam_ref * map.keyframes[r.ref_kf].T_cam_world).inverse();
      out.frames.poses.push_back(sp);
      out.status.push_back(r.status);
      out.frame_segment.push_back(r.segment);
    }
    out.keyframes.source = "StereoSlam keyframes";
    for (const Keyframe& kf : map.keyframes) {
      if (kf.bad) continue;
      out.keyframes.poses.push_back({kf.t_ns, kf.T_cam_world.inverse()});
    }
    stats.keyframes = static_cast<int>(out.keyframes.poses.size());
    stats.map_points = 0;
    for (const MapPoint& p : map.points) stats.map_points += !p.bad;
    stats.finish_s = Seconds(t0);
    out.stats = stats;
    out.map = std::move(map);
    return out;
  }
};

StereoSlam::StereoSlam(const StereoCalibration& rectified, const SlamOptions& options) : impl_(std::make_unique<Impl>()) {
  options.Check();
  if (!rectified.rectified)
    throw std::invalid_argument("StereoSlam needs a rectified calibration (rectify raw pairs with StereoRectifier)");
  const double b = rectified.BaselineM();
  if (!(b > 0) || !(rectified.left.fx > 0) || rectified.left.width <= 0 || rectified.left.height <= 0)
    throw std::invalid_argument(fmt::format("StereoSlam: calibration needs baseline > 0, fx > 0 and an image size (baseline {} m, fx {} px, {}x{})",
                                            b, rectified.left.fx, rectified.left.width, rectified.left.height));
  Impl& s = *impl_;
  s.opt = options;
  s.cam.fx = rectified.left.fx;
  s.cam.fy = rectified.left.fy;
  s.cam.cx = rectified.left.cx;
  s.cam.cy = rectified.left.cy;
  s.cam.baseline_m = b;
  s.cam.width = rectified.left.width;
  s.cam.height = rectified.left.height;
  s.pyr = ScalePyramid(options.pyramid_levels, options.scale_factor);
  s.close_depth_m = options.close_depth_baselines * b;
}

StereoSlam::~StereoSlam() = default;

FrameResult StereoSlam::Track(int64_t t_ns, const cv::Mat& left, const cv::Mat& right,
                              const std::optional<PosePrior>& prior) {
  return impl_->Track(t_ns, left, right, prior);
}

FrameResult StereoSlam::Track(int64_t t_ns, StereoFeatures features, const std::optional<PosePrior>& prior) {
  return impl_->Track(t_ns, std::move(features), prior);
}

const StereoCamera& StereoSlam::camera() const { return impl_->cam; }
const SlamOptions& StereoSlam::options() const { return impl_->opt; }
const ScalePyramid& StereoSlam::pyramid() const { return impl_->pyr; }

SlamResult StereoSlam::Finish() { return impl_->Finish(); }

}  // namespace rs
