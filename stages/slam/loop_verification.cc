#include "stages/slam/loop_verification.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <set>

#include "stages/slam/pose_optimizer.h"

namespace rs {
namespace {

constexpr int kRotationBins = 30;  // 12-degree bins of the orientation difference
constexpr int kRansacIterations = 300;
constexpr int kMinRansacInliers = 12;   // below this the guided search has no pose worth refining
constexpr int kGuidedMaxHamming = 50;   // ORB-SLAM2's TH_LOW for searches with a known pose
constexpr double kGuidedRadiusPx = 8;   // x pyramid scale; the RANSAC pose is good to a few px
constexpr int kLocalMapKeyframes = 10;  // covisible keyframes of the candidate searched

Eigen::Vector3d Backproject(const RectifiedStereo& cam, const StereoFeatures& f, int i) {
  const double z = f.depth_m[i];
  return {(f.keypoints[i].pt.x - cam.cx_px) * z / cam.f_px, (f.keypoints[i].pt.y - cam.cy_px) * z / cam.f_px, z};
}

// Chi-square of camera point p against feature i's stereo (u, v, u_right) measurement at its level's sigma.
double StereoChi2(const RectifiedStereo& cam, const StereoFeatures& f, int i, const Eigen::Vector3d& p,
                  const ScalePyramid& pyr) {
  if (p.z() <= 1e-6) return 1e9;
  const double iz = 1.0 / p.z();
  const cv::KeyPoint& kp = f.keypoints[i];
  const double du = kp.pt.x - (cam.f_px * p.x() * iz + cam.cx_px);
  const double dv = kp.pt.y - (cam.f_px * p.y() * iz + cam.cy_px);
  const double dr = f.u_right[i] - (cam.f_px * (p.x() - cam.baseline_m) * iz + cam.cx_px);
  return (du * du + dv * dv + dr * dr) * pyr.inv_sigma2[kp.octave];
}

// Keeps the matches whose orientation difference falls in the three most populated bins (bins
// below a tenth of the largest are dropped), as ORB-SLAM2's ORBmatcher does.
std::vector<std::pair<int, int>> RotationConsistent(const StereoFeatures& a, const StereoFeatures& b,
                                                    const std::vector<std::pair<int, int>>& matches) {
  std::array<std::vector<int>, kRotationBins> bins;
  for (size_t k = 0; k < matches.size(); ++k) {
    double d = a.keypoints[matches[k].first].angle - b.keypoints[matches[k].second].angle;
    d -= 360.0 * std::floor(d / 360.0);
    const int bin = std::min(kRotationBins - 1, static_cast<int>(d * kRotationBins / 360.0));
    bins[bin].push_back(static_cast<int>(k));
  }
  std::array<int, kRotationBins> order;
  for (int i = 0; i < kRotationBins; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return bins[x].size() > bins[y].size(); });
  const size_t largest = bins[order[0]].size();
  std::vector<char> keep(matches.size(), 0);
  for (int r = 0; r < 3; ++r) {
    const auto& bin = bins[order[r]];
    if (bin.empty() || bin.size() < 0.1 * largest) break;
    for (int k : bin) keep[k] = 1;
  }
  std::vector<std::pair<int, int>> out;
  for (size_t k = 0; k < matches.size(); ++k)
    if (keep[k]) out.push_back(matches[k]);
  return out;
}

}  // namespace

std::vector<std::pair<int, int>> MatchByDescriptor(const StereoFeatures& a, const std::vector<int>& a_index,
                                                   const StereoFeatures& b, const std::vector<int>& b_index,
                                                   int max_hamming, double ratio) {
  std::vector<int> b_best_dist(b.size(), 257), b_best_a(b.size(), -1);
  std::vector<std::pair<int, int>> tentative;
  for (int i : a_index) {
    const uint8_t* da = a.descriptors.ptr<uint8_t>(i);
    int best = 257, second = 257, best_j = -1;
    for (int j : b_index) {
      const int d = DescriptorDistance(da, b.descriptors.ptr<uint8_t>(j));
      if (d < best) {
        second = best;
        best = d;
        best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_j < 0 || best > max_hamming || best >= ratio * second) continue;
    if (best < b_best_dist[best_j]) {
      b_best_dist[best_j] = best;
      b_best_a[best_j] = i;
    }
    tentative.emplace_back(i, best_j);
  }
  std::vector<std::pair<int, int>> unique;
  for (auto [i, j] : tentative)
    if (b_best_a[j] == i) unique.emplace_back(i, j);
  return RotationConsistent(a, b, unique);
}

LoopVerification VerifyLoopCandidate(const SlamMap& map, int query, int candidate, const RectifiedStereo& cam,
                                     const ScalePyramid& pyr, int min_inliers, unsigned seed) {
  LoopVerification out;
  const Keyframe& q = map.keyframes[query];
  const Keyframe& c = map.keyframes[candidate];
  // 1. Descriptor matches between the stereo features (both sides have a 3-D point in their camera).
  std::vector<int> qi, ci;
  for (size_t i = 0; i < q.features.size(); ++i)
    if (q.features.depth_m[i] > 0) qi.push_back(static_cast<int>(i));
  for (size_t i = 0; i < c.features.size(); ++i)
    if (c.features.depth_m[i] > 0) ci.push_back(static_cast<int>(i));
  const std::vector<std::pair<int, int>> m = MatchByDescriptor(q.features, qi, c.features, ci, 64, 0.8);
  out.descriptor_matches = static_cast<int>(m.size());
  if (static_cast<int>(m.size()) < kMinRansacInliers) return out;

  // 2. 3D-3D RANSAC: T maps candidate-camera points into the query camera; an inlier reprojects
  //    within the stereo chi-square both ways.
  std::vector<Eigen::Vector3d> pq(m.size()), pc(m.size());
  for (size_t k = 0; k < m.size(); ++k) {
    pq[k] = Backproject(cam, q.features, m[k].first);
    pc[k] = Backproject(cam, c.features, m[k].second);
  }
  auto count_inliers = [&](const Eigen::Isometry3d& T, std::vector<int>* in) {
    in->clear();
    const Eigen::Isometry3d Ti = T.inverse();
    for (size_t k = 0; k < m.size(); ++k)
      if (StereoChi2(cam, q.features, m[k].first, T * pc[k], pyr) < kChi2Stereo &&
          StereoChi2(cam, c.features, m[k].second, Ti * pq[k], pyr) < kChi2Stereo)
        in->push_back(static_cast<int>(k));
  };
  std::mt19937 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, m.size() - 1);
  std::vector<int> best_in, in;
  Eigen::Isometry3d T_qc = Eigen::Isometry3d::Identity();
  for (int iter = 0; iter < kRansacIterations; ++iter) {
    const size_t s[3] = {pick(rng), pick(rng), pick(rng)};
    if (s[0] == s[1] || s[0] == s[2] || s[1] == s[2]) continue;
    Eigen::Matrix3d src, dst;
    for (int k = 0; k < 3; ++k) {
      src.col(k) = pc[s[k]];
      dst.col(k) = pq[s[k]];
    }
    if ((src.col(1) - src.col(0)).cross(src.col(2) - src.col(0)).norm() < 1e-6) continue;
    const Eigen::Isometry3d T(Eigen::umeyama(src, dst, false));
    count_inliers(T, &in);
    if (in.size() > best_in.size()) {
      best_in = in;
      T_qc = T;
    }
  }
  out.ransac_inliers = static_cast<int>(best_in.size());
  if (out.ransac_inliers < kMinRansacInliers) return out;
  // Least-squares fit on all RANSAC inliers.
  {
    Eigen::Matrix3Xd src(3, best_in.size()), dst(3, best_in.size());
    for (size_t k = 0; k < best_in.size(); ++k) {
      src.col(k) = pc[best_in[k]];
      dst.col(k) = pq[best_in[k]];
    }
    T_qc = Eigen::Isometry3d(Eigen::umeyama(src, dst, false));
    // Reprojection refinement (the 3D-3D fit weighs depth errors, which grow with depth squared).
    std::vector<PoseObservation> obs;
    for (int k : best_in) {
      PoseObservation o;
      const int i = m[k].first;
      o.p_world = pc[k];
      o.u = q.features.keypoints[i].pt.x;
      o.v = q.features.keypoints[i].pt.y;
      o.u_right = q.features.u_right[i];
      o.inv_sigma2 = pyr.inv_sigma2[q.features.keypoints[i].octave];
      obs.push_back(o);
    }
    OptimizePose(cam, &obs, &T_qc);
    for (const PoseObservation& o : obs) out.two_view_inliers += !o.outlier;
  }
  out.T_query_candidate = out.T_query_candidate_two_view = T_qc;
  out.accepted = out.two_view_inliers >= min_inliers;

  // 3. Guided search: the candidate's local map projected into the query, then motion-only BA;
  //    twice, the second round from the refined pose.
  std::vector<int> local_points;
  {
    std::set<int> seen;
    std::vector<int> kfs = {candidate};
    for (int k : c.BestCovisible(kLocalMapKeyframes)) kfs.push_back(k);
    for (int k : kfs)
      for (int p : map.keyframes[k].points)
        if (p >= 0 && !map.points[p].bad && seen.insert(p).second) local_points.push_back(p);
  }
  Eigen::Isometry3d T_qw = T_qc * c.T_cam_world;
  std::vector<std::pair<int, int>> matches;
  for (int round = 0; round < 2; ++round) {
    const double radius_factor = round == 0 ? kGuidedRadiusPx : kGuidedRadiusPx / 2;
    std::vector<int> feat_point(q.features.size(), -1), feat_dist(q.features.size(), 257);
    for (int p : local_points) {
      const MapPoint& mp = map.points[p];
      const Eigen::Vector3d x = T_qw * mp.p_world;
      if (x.z() <= 1e-6) continue;
      const double u = cam.f_px * x.x() / x.z() + cam.cx_px, v = cam.f_px * x.y() / x.z() + cam.cy_px;
      if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
      const double ur = u - cam.bf() / x.z();
      const int level = mp.max_distance_m > 0 ? pyr.PredictLevel(x.norm(), mp.max_distance_m) : 0;
      const double radius = radius_factor * pyr.scale[level];
      int best = 257, best_i = -1;
      for (int i : q.features.FeaturesInArea(u, v, radius, std::max(0, level - 1), level + 1)) {
        if (q.features.u_right[i] >= 0 && std::abs(q.features.u_right[i] - ur) > radius) continue;
        const int d = DescriptorDistance(mp.descriptor.ptr<uint8_t>(0), q.features.descriptors.ptr<uint8_t>(i));
        if (d < best) {
          best = d;
          best_i = i;
        }
      }
      if (best_i < 0 || best > kGuidedMaxHamming || best >= feat_dist[best_i]) continue;
      feat_dist[best_i] = best;
      feat_point[best_i] = p;
    }
    std::vector<PoseObservation> obs;
    matches.clear();
    for (size_t i = 0; i < q.features.size(); ++i) {
      if (feat_point[i] < 0) continue;
      PoseObservation o;
      o.p_world = map.points[feat_point[i]].p_world;
      o.u = q.features.keypoints[i].pt.x;
      o.v = q.features.keypoints[i].pt.y;
      o.u_right = q.features.u_right[i];
      o.inv_sigma2 = pyr.inv_sigma2[q.features.keypoints[i].octave];
      obs.push_back(o);
      matches.emplace_back(static_cast<int>(i), feat_point[i]);
    }
    if (static_cast<int>(obs.size()) < kMinRansacInliers) return out;
    OptimizePose(cam, &obs, &T_qw);
    std::vector<std::pair<int, int>> kept;
    for (size_t k = 0; k < obs.size(); ++k)
      if (!obs[k].outlier) kept.push_back(matches[k]);
    matches.swap(kept);
  }
  out.inliers = static_cast<int>(matches.size());
  out.T_query_world = T_qw;
  out.point_matches = std::move(matches);
  if (out.inliers >= min_inliers) {
    out.accepted = true;
    out.T_query_candidate = T_qw * c.T_cam_world.inverse();
  }
  return out;
}

}  // namespace rs
