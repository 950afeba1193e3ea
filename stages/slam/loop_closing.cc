#include "stages/slam/loop_closing.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Geometry>

#include "stages/slam/bundle_adjust.h"
#include "stages/slam/loop_verification.h"
#include "stages/slam/place_recognition.h"
#include "stages/slam/stereo_slam.h"

namespace rs {
namespace {

constexpr int kCandidatesPerSource = 3;  // nearest / best-scoring candidates taken from each source
// Odometry drift allowed for when comparing SLAM positions: a fraction of the path flown in between
// (well above the ~0.3 % this SLAM drifts on the simulated loop, so a true revisit is always in reach).
constexpr double kTrackDriftFraction = 0.02;

// Bag-of-words index over all keyframes, vocabulary built from this survey's own descriptors.
struct PlaceIndex {
  std::vector<BowVector> bow;
  std::vector<std::vector<int>> inverted;  // word -> keyframes
  int words = 0;
};

PlaceIndex BuildPlaceIndex(const SlamMap& map, const SlamOptions& opt) {
  const int n = static_cast<int>(map.keyframes.size());
  // At most ~60k training descriptors, evenly subsampled.
  std::vector<const uint8_t*> all;
  size_t total = 0;
  for (const Keyframe& kf : map.keyframes) total += kf.features.size();
  const size_t stride = std::max<size_t>(1, total / 60000);
  size_t c = 0;
  for (const Keyframe& kf : map.keyframes)
    for (size_t i = 0; i < kf.features.size(); ++i, ++c)
      if (c % stride == 0) all.push_back(kf.features.descriptors.ptr<uint8_t>(static_cast<int>(i)));
  const Vocabulary voc = Vocabulary::Build(all, opt.vocabulary_branching, opt.vocabulary_depth, opt.ransac_seed);
  std::vector<std::vector<int>> words(n);
  for (int k = 0; k < n; ++k) {
    const Keyframe& kf = map.keyframes[k];
    for (size_t i = 0; i < kf.features.size(); ++i)
      words[k].push_back(voc.Word(kf.features.descriptors.ptr<uint8_t>(static_cast<int>(i))));
  }
  PlaceIndex index;
  index.words = voc.words();
  index.bow = BowVectors(words, voc.words());
  index.inverted.resize(voc.words());
  for (int k = 0; k < n; ++k)
    for (auto& [w, x] : index.bow[k]) index.inverted[w].push_back(k);
  return index;
}

// Older keyframes are candidates even when they already share points with the query: after a turn on
// the spot, tracking follows the local map back onto the outbound keyframes, so a revisit is usually
// covisible by the time the loop closer runs; verifying it adds the loop edge and fuses the duplicates.
// Keyframes of another map segment (tracking was lost in between) are candidates at any age: merging
// the segments is what their loop edge is for.
bool Eligible(const SlamMap& map, int i, int j, int min_gap) {
  return !map.keyframes[j].bad && j < i && (j <= i - min_gap || map.keyframes[j].segment != map.keyframes[i].segment);
}

// Appearance: older keyframes scoring at least the query's worst covisible neighbour (DBoW2 / ORB-SLAM2 rule).
std::vector<int> AppearanceCandidates(const SlamMap& map, const PlaceIndex& index, int i, int min_gap) {
  const Keyframe& kf = map.keyframes[i];
  double min_score = 1.0;
  for (int nb : kf.BestCovisible(10)) min_score = std::min(min_score, BowScore(index.bow[i], index.bow[nb]));
  if (kf.covisibility.empty()) min_score = 0.0;
  std::set<int> shared;
  for (auto& [w, x] : index.bow[i])
    for (int j : index.inverted[w])
      if (j < i) shared.insert(j);
  std::vector<std::pair<double, int>> scored;
  for (int j : shared) {
    if (!Eligible(map, i, j, min_gap)) continue;
    const double s = BowScore(index.bow[i], index.bow[j]);
    if (s >= min_score) scored.emplace_back(-s, j);
  }
  std::sort(scored.begin(), scored.end());
  std::vector<int> out;
  for (size_t q = 0; q < scored.size() && static_cast<int>(q) < kCandidatesPerSource; ++q)
    out.push_back(scored[q].second);
  return out;
}

// Nearest older keyframes by `distance` (NaN = not comparable), within `radius(j)`.
template <typename Distance, typename Radius>
std::vector<int> NearestCandidates(const SlamMap& map, int i, int min_gap, Distance distance, Radius radius) {
  std::vector<std::pair<double, int>> near;
  for (int j = 0; j < i; ++j) {
    if (!Eligible(map, i, j, min_gap)) continue;
    const double d = distance(j);
    if (d < radius(j)) near.emplace_back(d, j);
  }
  std::sort(near.begin(), near.end());
  std::vector<int> out;
  for (size_t q = 0; q < near.size() && static_cast<int>(q) < kCandidatesPerSource; ++q) out.push_back(near[q].second);
  return out;
}

// Half the smaller side of a keyframe's ground footprint (median stereo depth): centres closer than
// this see overlapping ground.
double OverlapRadius(const Keyframe& kf, const RectifiedStereo& cam) {
  std::vector<float> depth;
  for (float d : kf.features.depth_m)
    if (d > 0) depth.push_back(d);
  if (depth.empty()) return 0;
  std::nth_element(depth.begin(), depth.begin() + depth.size() / 2, depth.end());
  return 0.5 * depth[depth.size() / 2] * std::min(cam.width / cam.f_px, cam.height / cam.f_px);
}

}  // namespace

std::vector<LoopClosure> DetectAndCloseLoops(SlamMap* map, const RectifiedStereo& cam, const ScalePyramid& pyr,
                                             const SlamOptions& opt, SlamStatistics* stats,
                                             std::atomic<bool>* loop_accepted) {
  std::vector<LoopClosure> loops;
  const int n = static_cast<int>(map->keyframes.size());
  if (n < 2) return loops;
  const PlaceIndex index = BuildPlaceIndex(*map, opt);
  stats->vocabulary_words = index.words;
  // Position along the SLAM track (uncorrected; drift is small over short stretches, and a new map
  // segment starts at the motion-model prediction, so positions stay comparable across segments).
  std::vector<Eigen::Vector3d> centre(n);
  std::vector<double> travelled(n, 0.0);
  for (int k = 0; k < n; ++k) {
    centre[k] = map->keyframes[k].Center();
    if (k > 0) travelled[k] = travelled[k - 1] + (centre[k] - centre[k - 1]).norm();
  }

  struct Accepted {
    int a, b;
    Eigen::Isometry3d T_a_b;
    std::vector<std::pair<int, int>> matches;  // (feature of a, map point)
  };
  std::vector<Accepted> accepted;
  for (int i = 1; i < n; ++i) {
    const Keyframe& kf = map->keyframes[i];
    if (kf.bad) continue;
    const int gap = opt.loop_min_gap_keyframes;
    std::vector<std::pair<int, bool>> cand;  // (keyframe, found by position)
    auto add = [&](int j, bool by_position) {
      if (std::none_of(cand.begin(), cand.end(), [&](auto& c) { return c.first == j; }))
        cand.emplace_back(j, by_position);
    };
    // Track proximity first (the most precise position), then GNSS priors, then appearance.
    const double overlap = OverlapRadius(kf, cam);
    for (int j : NearestCandidates(
             *map, i, gap, [&](int j) { return (centre[j] - centre[i]).norm(); },
             [&](int j) { return overlap + kTrackDriftFraction * (travelled[i] - travelled[j]); }))
      add(j, true);
    if (kf.prior && kf.prior->has_position) {
      const Eigen::Vector3d p = kf.prior->T_world_cam.translation();
      for (int j : NearestCandidates(
               *map, i, gap,
               [&](int j) {
                 const auto& o = map->keyframes[j].prior;
                 return o && o->has_position ? (o->T_world_cam.translation() - p).norm() : 1e300;
               },
               [&](int) { return opt.loop_prior_radius_m; }))
        add(j, true);
    }
    for (int j : AppearanceCandidates(*map, index, i, gap)) add(j, false);

    for (auto [j, by_position] : cand) {
      ++stats->loop_candidates;
      const LoopVerification v = VerifyLoopCandidate(
          *map, i, j, cam, pyr, opt.loop_min_inliers,
          opt.ransac_seed * 2654435761u + static_cast<unsigned>(i) * 7919u + static_cast<unsigned>(j));
      if (!v.accepted) {
        ++stats->loops_rejected;
        continue;
      }
      // Look-alike places: the verified relative pose must agree with the priors' distance.
      const Keyframe& o = map->keyframes[j];
      if (kf.prior && o.prior && kf.prior->has_position && o.prior->has_position) {
        const double d_prior = (kf.prior->T_world_cam.translation() - o.prior->T_world_cam.translation()).norm();
        const double sigma = std::hypot(kf.prior->sigma_position_m, o.prior->sigma_position_m);
        if (std::abs(v.T_query_candidate.translation().norm() - d_prior) > opt.loop_prior_gate_m + 3 * sigma) {
          ++stats->loops_rejected;
          continue;
        }
      }
      accepted.push_back({i, j, v.T_query_candidate, v.point_matches});
      if (loop_accepted != nullptr) *loop_accepted = true;
      LoopClosure lc;
      lc.keyframe = i;
      lc.loop_keyframe = j;
      lc.inliers = std::max(v.inliers, v.two_view_inliers);
      lc.by_prior = by_position;
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
  // Fuse the re-observed points so the global BA ties both passes together.
  for (const Accepted& a : accepted) {
    for (auto [f, p] : a.matches) {
      if (map->points[p].bad) continue;
      const int mine = map->keyframes[a.a].points[f];
      if (mine == p) continue;
      if (mine >= 0 && !map->points[mine].bad) {
        map->Replace(mine, p);
      } else if (!map->points[p].observations.count(a.a)) {
        map->AddObservation(p, a.a, f);
      }
    }
  }
  for (int k = 0; k < n; ++k)
    if (!map->keyframes[k].bad) map->UpdateCovisibility(k);
  return loops;
}

}  // namespace rs
