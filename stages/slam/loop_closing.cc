#include "stages/slam/loop_closing.h"

#include <algorithm>
#include <random>
#include <set>

#include <Eigen/Geometry>

#include "stages/slam/bundle_adjust.h"
#include "stages/slam/place_recognition.h"
#include "stages/slam/pose_optimizer.h"
#include "stages/slam/stereo_slam.h"

namespace rs {
namespace {

Eigen::Vector3d Backproject(const StereoCamera& cam, const StereoFeatures& f, int i) {
  const double z = f.depth_m[i];
  return {(f.keypoints[i].pt.x - cam.cx) * z / cam.fx, (f.keypoints[i].pt.y - cam.cy) * z / cam.fy, z};
}

// chi2 of point p (camera frame) against feature i's stereo measurement.
double StereoChi2(const StereoCamera& cam, const StereoFeatures& f, int i, const Eigen::Vector3d& p,
                  const ScalePyramid& pyr) {
  if (p.z() <= 1e-6) return 1e9;
  const double iz = 1.0 / p.z();
  const cv::KeyPoint& kp = f.keypoints[i];
  const double e2 = std::pow(kp.pt.x - (cam.fx * p.x() * iz + cam.cx), 2) + std::pow(kp.pt.y - (cam.fy * p.y() * iz + cam.cy), 2) +
                    std::pow(f.u_right[i] - (cam.fx * (p.x() - cam.baseline_m) * iz + cam.cx), 2);
  return e2 * pyr.inv_sigma2[kp.octave];
}

// Mutual best descriptor matches between stereo features of a and b with a ratio test.
std::vector<std::pair<int, int>> MatchStereoFeatures(const StereoFeatures& a, const StereoFeatures& b) {
  std::vector<int> ia, ib;
  for (size_t i = 0; i < a.size(); ++i)
    if (a.depth_m[i] > 0) ia.push_back(static_cast<int>(i));
  for (size_t i = 0; i < b.size(); ++i)
    if (b.depth_m[i] > 0) ib.push_back(static_cast<int>(i));
  std::vector<int> best_ab(a.size(), -1), best_ba_dist(b.size(), 257), best_ba(b.size(), -1);
  for (int i : ia) {
    int best = 257, second = 257, bj = -1;
    for (int j : ib) {
      const int d = DescriptorDistance(a.descriptors.ptr<uint8_t>(i), b.descriptors.ptr<uint8_t>(j));
      if (d < best) {
        second = best;
        best = d;
        bj = j;
      } else if (d < second) {
        second = d;
      }
      if (d < best_ba_dist[j]) {
        best_ba_dist[j] = d;
        best_ba[j] = i;
      }
    }
    if (bj >= 0 && best <= 64 && best < 0.8 * second) best_ab[i] = bj;
  }
  std::vector<std::pair<int, int>> out;
  for (int i : ia)
    if (best_ab[i] >= 0 && best_ba[best_ab[i]] == i) out.emplace_back(i, best_ab[i]);
  return out;
}

}  // namespace

bool VerifyStereoPair(const Keyframe& a, const Keyframe& b, const StereoCamera& cam, const ScalePyramid& pyr,
                      int min_inliers, unsigned seed, Eigen::Isometry3d* T_a_b, std::vector<std::pair<int, int>>* pairs) {
  const std::vector<std::pair<int, int>> m = MatchStereoFeatures(a.features, b.features);
  if (static_cast<int>(m.size()) < min_inliers) return false;
  std::vector<Eigen::Vector3d> pa(m.size()), pb(m.size());
  for (size_t k = 0; k < m.size(); ++k) {
    pa[k] = Backproject(cam, a.features, m[k].first);
    pb[k] = Backproject(cam, b.features, m[k].second);
  }
  auto inliers_of = [&](const Eigen::Isometry3d& T, std::vector<int>* in) {
    in->clear();
    const Eigen::Isometry3d Ti = T.inverse();
    for (size_t k = 0; k < m.size(); ++k)
      if (StereoChi2(cam, a.features, m[k].first, T * pb[k], pyr) < kChi2Stereo &&
          StereoChi2(cam, b.features, m[k].second, Ti * pa[k], pyr) < kChi2Stereo)
        in->push_back(static_cast<int>(k));
  };
  std::mt19937 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, m.size() - 1);
  std::vector<int> best_in, in;
  Eigen::Isometry3d best_T = Eigen::Isometry3d::Identity();
  for (int iter = 0; iter < 300; ++iter) {
    size_t s[3] = {pick(rng), pick(rng), pick(rng)};
    if (s[0] == s[1] || s[0] == s[2] || s[1] == s[2]) continue;
    Eigen::Matrix3d src, dst;
    for (int c = 0; c < 3; ++c) {
      src.col(c) = pb[s[c]];
      dst.col(c) = pa[s[c]];
    }
    if ((src.col(1) - src.col(0)).cross(src.col(2) - src.col(0)).norm() < 1e-6) continue;
    Eigen::Isometry3d T(Eigen::umeyama(src, dst, false));
    inliers_of(T, &in);
    if (in.size() > best_in.size()) {
      best_in = in;
      best_T = T;
    }
  }
  if (static_cast<int>(best_in.size()) < min_inliers) return false;
  // Refine T_a_b as a camera pose observing b's points (motion-only BA), then re-count.
  std::vector<PoseObservation> obs;
  for (int k : best_in) {
    PoseObservation o;
    const int i = m[k].first;
    o.p_world = pb[k];
    o.u = a.features.keypoints[i].pt.x;
    o.v = a.features.keypoints[i].pt.y;
    o.u_right = a.features.u_right[i];
    o.inv_sigma2 = pyr.inv_sigma2[a.features.keypoints[i].octave];
    obs.push_back(o);
  }
  OptimizePose(cam, &obs, &best_T);
  inliers_of(best_T, &in);
  if (static_cast<int>(in.size()) < min_inliers) return false;
  *T_a_b = best_T;
  pairs->clear();
  for (int k : in) pairs->push_back(m[k]);
  return true;
}

std::vector<LoopClosure> DetectAndCloseLoops(SlamMap* map, const StereoCamera& cam, const ScalePyramid& pyr,
                                             const SlamOptions& opt, SlamStatistics* stats) {
  std::vector<LoopClosure> loops;
  const int n = static_cast<int>(map->keyframes.size());
  if (n <= opt.loop_min_gap_keyframes) return loops;
  // Vocabulary from this survey's own descriptors (at most ~60k, evenly subsampled).
  std::vector<const uint8_t*> all;
  size_t total = 0;
  for (const Keyframe& kf : map->keyframes) total += kf.features.size();
  const size_t stride = std::max<size_t>(1, total / 60000);
  size_t c = 0;
  for (const Keyframe& kf : map->keyframes)
    for (size_t i = 0; i < kf.features.size(); ++i, ++c)
      if (c % stride == 0) all.push_back(kf.features.descriptors.ptr<uint8_t>(static_cast<int>(i)));
  const Vocabulary voc = Vocabulary::Build(all, opt.vocabulary_branching, opt.vocabulary_depth, opt.ransac_seed);
  stats->vocabulary_words = voc.words();
  std::vector<std::vector<int>> words(n);
  for (int k = 0; k < n; ++k) {
    const Keyframe& kf = map->keyframes[k];
    for (size_t i = 0; i < kf.features.size(); ++i)
      words[k].push_back(voc.Word(kf.features.descriptors.ptr<uint8_t>(static_cast<int>(i))));
  }
  const std::vector<BowVector> bow = BowVectors(words, voc.words());
  std::vector<std::vector<int>> inverted(voc.words());
  for (int k = 0; k < n; ++k)
    for (auto& [w, x] : bow[k]) inverted[w].push_back(k);

  struct Accepted {
    int a, b;
    Eigen::Isometry3d T_a_b;
    std::vector<std::pair<int, int>> pairs;
  };
  std::vector<Accepted> accepted;
  for (int i = opt.loop_min_gap_keyframes; i < n; ++i) {
    const Keyframe& kf = map->keyframes[i];
    if (kf.bad) continue;
    double min_score = 1.0;
    for (int nb : kf.BestCovisible(10)) min_score = std::min(min_score, BowScore(bow[i], bow[nb]));
    if (kf.covisibility.empty()) min_score = 0.0;
    std::set<int> shared;
    for (auto& [w, x] : bow[i])
      for (int j : inverted[w])
        if (j < i - opt.loop_min_gap_keyframes) shared.insert(j);
    std::vector<std::pair<double, int>> scored;
    for (int j : shared) {
      if (map->keyframes[j].bad || kf.covisibility.count(j)) continue;
      const double s = BowScore(bow[i], bow[j]);
      if (s >= min_score) scored.emplace_back(-s, j);
    }
    std::sort(scored.begin(), scored.end());
    std::vector<std::pair<int, bool>> cand;  // (keyframe, by prior)
    for (size_t q = 0; q < scored.size() && q < 3; ++q) cand.emplace_back(scored[q].second, false);
    if (kf.prior && kf.prior->has_position) {
      std::vector<std::pair<double, int>> near;
      for (int j = 0; j < i - opt.loop_min_gap_keyframes; ++j) {
        const Keyframe& o = map->keyframes[j];
        if (o.bad || !o.prior || !o.prior->has_position || kf.covisibility.count(j)) continue;
        const double d = (o.prior->T_world_cam.translation() - kf.prior->T_world_cam.translation()).norm();
        if (d < opt.loop_prior_radius_m) near.emplace_back(d, j);
      }
      std::sort(near.begin(), near.end());
      for (size_t q = 0; q < near.size() && q < 2; ++q)
        if (std::none_of(cand.begin(), cand.end(), [&](auto& p) { return p.first == near[q].second; }))
          cand.emplace_back(near[q].second, true);
    }
    for (auto [j, by_prior] : cand) {
      ++stats->loop_candidates;
      Eigen::Isometry3d T_i_j;
      std::vector<std::pair<int, int>> pairs;
      if (!VerifyStereoPair(kf, map->keyframes[j], cam, pyr, opt.loop_min_inliers,
                            opt.ransac_seed * 2654435761u + static_cast<unsigned>(i) * 7919u + static_cast<unsigned>(j),
                            &T_i_j, &pairs)) {
        ++stats->loops_rejected;
        continue;
      }
      // Look-alike places: the verified relative pose must agree with the priors' distance.
      const Keyframe& o = map->keyframes[j];
      if (kf.prior && o.prior && kf.prior->has_position && o.prior->has_position) {
        const double d_prior = (kf.prior->T_world_cam.translation() - o.prior->T_world_cam.translation()).norm();
        const double sigma = std::hypot(kf.prior->sigma_position_m, o.prior->sigma_position_m);
        if (std::abs(T_i_j.translation().norm() - d_prior) > opt.loop_prior_gate_m + 3 * sigma) {
          ++stats->loops_rejected;
          continue;
        }
      }
      accepted.push_back({i, j, T_i_j, pairs});
      LoopClosure lc;
      lc.keyframe = i;
      lc.loop_keyframe = j;
      lc.inliers = static_cast<int>(pairs.size());
      lc.by_prior = by_prior;
      loops.push_back(lc);
      break;
    }
  }
  stats->loops_closed = static_cast<int>(loops.size());
  if (accepted.empty()) return loops;

  // Pose graph: sequential edges, strong covisibility edges, loop edges; keyframe 0 fixed.
  std::vector<Eigen::Isometry3d> T_world_kf(n), before(n);
  for (int k = 0; k < n; ++k) before[k] = T_world_kf[k] = map->keyframes[k].T_cam_world.inverse();
  std::vector<PoseGraphEdge> edges;
  for (int k = 1; k < n; ++k) {
    const bool same = map->keyframes[k].segment == map->keyframes[k - 1].segment;
    edges.push_back({k - 1, k, T_world_kf[k - 1].inverse() * T_world_kf[k], same ? 1.0 : 1e-4});
    for (auto& [o, w] : map->keyframes[k].covisibility)
      if (o < k - 1 && w >= 100) edges.push_back({o, k, T_world_kf[o].inverse() * T_world_kf[k], 1.0});
  }
  for (const Accepted& a : accepted) edges.push_back({a.a, a.b, a.T_a_b, 1.0});
  OptimizePoseGraph(&T_world_kf, edges, {0}, 50);
  for (MapPoint& p : map->points) {
    if (p.bad || p.reference_kf < 0) continue;
    p.p_world = T_world_kf[p.reference_kf] * (before[p.reference_kf].inverse() * p.p_world);
  }
  for (int k = 0; k < n; ++k) map->keyframes[k].T_cam_world = T_world_kf[k].inverse();
  // Fuse re-observed points so the global BA ties both passes together.
  for (const Accepted& a : accepted) {
    for (auto [fa, fb] : a.pairs) {
      const int pa = map->keyframes[a.a].points[fa], pb = map->keyframes[a.b].points[fb];
      if (pb >= 0 && !map->points[pb].bad) {
        if (pa >= 0 && !map->points[pa].bad) {
          if (pa != pb) map->Replace(pa, pb);
        } else if (!map->points[pb].observations.count(a.a)) {
          map->AddObservation(pb, a.a, fa);
        }
      } else if (pa >= 0 && !map->points[pa].bad && !map->points[pa].observations.count(a.b)) {
        map->AddObservation(pa, a.b, fb);
      }
    }
    map->UpdateCovisibility(a.a);
    map->UpdateCovisibility(a.b);
  }
  return loops;
}

}  // namespace rs
