#include "stages/slam/slam_map.h"

#include <algorithm>
#include <cstring>

namespace rs {

std::vector<int> Keyframe::BestCovisible(int max_count, int min_weight) const {
  std::vector<std::pair<int, int>> v;
  for (auto& [id, w] : covisibility)
    if (w >= min_weight) v.emplace_back(-w, id);
  std::sort(v.begin(), v.end());
  std::vector<int> out;
  for (auto& [w, id] : v) {
    if (static_cast<int>(out.size()) >= max_count) break;
    out.push_back(id);
  }
  return out;
}

int SlamMap::AddPoint(const Eigen::Vector3d& p_world, int kf, int feature) {
  MapPoint mp;
  mp.id = static_cast<int>(points.size());
  mp.p_world = p_world;
  mp.reference_kf = kf;
  mp.descriptor = keyframes[kf].features.descriptors.row(feature).clone();
  points.push_back(std::move(mp));
  AddObservation(points.back().id, kf, feature);
  return points.back().id;
}

void SlamMap::AddObservation(int point, int kf, int feature) {
  points[point].observations[kf] = feature;
  keyframes[kf].points[feature] = point;
}

void SlamMap::EraseObservation(int point, int kf) {
  MapPoint& mp = points[point];
  auto it = mp.observations.find(kf);
  if (it == mp.observations.end()) return;
  if (keyframes[kf].points[it->second] == point) keyframes[kf].points[it->second] = -1;
  mp.observations.erase(it);
  if (mp.reference_kf == kf && !mp.observations.empty()) mp.reference_kf = mp.observations.begin()->first;
  // A stereo observation fixes a point on its own; a single mono one does not.
  if (mp.observations.empty()) {
    SetBad(point);
  } else if (mp.observations.size() == 1) {
    const auto& [k, f] = *mp.observations.begin();
    if (keyframes[k].features.u_right[f] < 0) SetBad(point);
  }
}

void SlamMap::SetBad(int point) {
  MapPoint& mp = points[point];
  mp.bad = true;
  for (auto& [kf, feat] : mp.observations)
    if (keyframes[kf].points[feat] == point) keyframes[kf].points[feat] = -1;
  mp.observations.clear();
}

void SlamMap::Replace(int from, int into) {
  if (from == into) return;
  MapPoint& a = points[from];
  MapPoint& b = points[into];
  for (auto& [kf, feat] : a.observations) {
    if (b.observations.count(kf)) {
      if (keyframes[kf].points[feat] == from) keyframes[kf].points[feat] = -1;
    } else {
      b.observations[kf] = feat;
      keyframes[kf].points[feat] = into;
    }
  }
  b.visible += a.visible;
  b.found += a.found;
  a.observations.clear();
  a.bad = true;
  a.replaced_by = into;
}

void SlamMap::UpdateCovisibility(int kf) {
  Keyframe& k = keyframes[kf];
  std::map<int, int> counts;
  for (int p : k.points) {
    if (p < 0 || points[p].bad) continue;
    for (auto& [other, feat] : points[p].observations)
      if (other != kf) ++counts[other];
  }
  for (auto& [other, w] : k.covisibility) keyframes[other].covisibility.erase(kf);
  k.covisibility.clear();
  for (auto& [other, w] : counts) {
    if (w < 15 && counts.size() > 1) continue;
    k.covisibility[other] = w;
    keyframes[other].covisibility[kf] = w;
  }
  if (k.covisibility.empty() && !counts.empty()) {  // keep at least the strongest link
    auto best = std::max_element(counts.begin(), counts.end(), [](auto& a, auto& b) { return a.second < b.second; });
    k.covisibility[best->first] = best->second;
    keyframes[best->first].covisibility[kf] = best->second;
  }
}

void SlamMap::UpdatePointDescriptor(int point) {
  MapPoint& mp = points[point];
  std::vector<const uint8_t*> d;
  for (auto& [kf, feat] : mp.observations) d.push_back(keyframes[kf].features.descriptors.ptr<uint8_t>(feat));
  if (d.empty()) return;
  const size_t n = d.size();
  int best = INT32_MAX;
  size_t best_i = 0;
  std::vector<int> row(n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) row[j] = DescriptorDistance(d[i], d[j]);
    std::nth_element(row.begin(), row.begin() + (n - 1) / 2, row.end());
    if (row[(n - 1) / 2] < best) {
      best = row[(n - 1) / 2];
      best_i = i;
    }
  }
  std::memcpy(mp.descriptor.ptr<uint8_t>(0), d[best_i], 32);
}

void SlamMap::UpdatePointGeometry(int point, const ScalePyramid& pyramid) {
  MapPoint& mp = points[point];
  if (mp.observations.empty()) return;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (auto& [kf, feat] : mp.observations) normal += (mp.p_world - keyframes[kf].Center()).normalized();
  mp.normal = normal.normalized();
  const Keyframe& ref = keyframes[mp.reference_kf];
  auto it = mp.observations.find(mp.reference_kf);
  const int level = it != mp.observations.end() ? ref.features.keypoints[it->second].octave : 0;
  const double dist = (mp.p_world - ref.Center()).norm();
  mp.max_distance_m = dist * pyramid.scale[level];
  mp.min_distance_m = mp.max_distance_m / pyramid.scale.back();
}

}  // namespace rs
