#include "stages/slam/disparity_calibration.h"

#include "survey/stats/order_statistic.h"
#include "survey/stats/robust_stats.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <utility>

namespace rs {
namespace {

double Median(std::vector<double> v) { return v.empty() ? 0 : LowerMedianInPlace(v); }

}  // namespace

DisparityOffsetEstimate EstimateDisparityOffset(const std::vector<DisparityPairSample>& samples, int num_pairs,
                                                double bf, int min_samples, double max_sigma_px) {
  DisparityOffsetEstimate out;
  // Pairs with too few samples cannot fix their own tz: leave them out.
  constexpr int kMinPerPair = 10;
  std::vector<int> count(num_pairs, 0);
  for (const auto& s : samples)
    if (s.pair >= 0 && s.pair < num_pairs && s.d_i > 0 && s.d_j > 0) ++count[s.pair];
  std::vector<int> index(num_pairs, -1);
  int pairs = 0;
  for (int p = 0; p < num_pairs; ++p)
    if (count[p] >= kMinPerPair) index[p] = pairs++;
  std::vector<DisparityPairSample> s;
  for (const auto& x : samples)
    if (x.pair >= 0 && x.pair < num_pairs && index[x.pair] >= 0 && x.d_i > 0 && x.d_j > 0) {
      s.push_back(x);
      s.back().pair = index[x.pair];
    }
  out.pairs = pairs;
  out.samples = static_cast<int>(s.size());
  if (pairs < 3 || out.samples < min_samples) return out;

  double o = 0;
  std::vector<double> tz(pairs, 0);
  {
    std::vector<std::vector<double>> dz(pairs);
    for (const auto& x : s) dz[x.pair].push_back(bf / x.d_j - x.a * bf / x.d_i);
    for (int p = 0; p < pairs; ++p) tz[p] = Median(dz[p]);
  }
  const size_t n = s.size();
  std::vector<double> r(n), jo(n), jt(n), var(n), w(n);
  double sigma = 1, h_oo_reduced = 0;
  for (int iter = 0; iter < 20; ++iter) {
    // Residual in disparity at j, whitened by the noise of both measurements (unit disparity noise).
    std::vector<double> rw;
    rw.reserve(n);
    for (size_t k = 0; k < n; ++k) {
      const auto& x = s[k];
      const double zi = bf / (x.d_i + o), zj = x.a * zi + tz[x.pair];
      if (!(x.d_i + o > 0) || !(zj > 0)) {
        var[k] = -1;
        continue;
      }
      const double q = x.a * (zi / zj) * (zi / zj);  // d(bf / zj) / d(d_i)
      r[k] = x.d_j + o - bf / zj;
      jo[k] = 1 - q;
      jt[k] = bf / (zj * zj);
      var[k] = 1 + q * q;
      rw.push_back(std::abs(r[k]) / std::sqrt(var[k]));
    }
    if (rw.size() < static_cast<size_t>(min_samples)) return out;
    sigma = std::max(1e-6, SigmaOfMedianAbs(Median(rw)));
    // Huber weights (k = 1.345 sigma), samples beyond 5 sigma dropped (wrong matches).
    int kept = 0;
    for (size_t k = 0; k < n; ++k) {
      if (var[k] <= 0) {
        w[k] = 0;
        continue;
      }
      const double e = std::abs(r[k]) / std::sqrt(var[k]);
      w[k] = e > 5 * sigma ? 0 : (e <= 1.345 * sigma ? 1 : 1.345 * sigma / e);
      w[k] /= var[k];
      kept += w[k] > 0;
    }
    out.samples = kept;
    // Normal equations, the per-pair tz eliminated (Schur complement onto o).
    std::vector<double> h_pp(pairs, 0), h_op(pairs, 0), g_p(pairs, 0);
    double h_oo = 0, g_o = 0;
    for (size_t k = 0; k < n; ++k) {
      if (w[k] <= 0) continue;
      const int p = s[k].pair;
      h_oo += w[k] * jo[k] * jo[k];
      g_o += w[k] * jo[k] * r[k];
      h_op[p] += w[k] * jo[k] * jt[k];
      h_pp[p] += w[k] * jt[k] * jt[k];
      g_p[p] += w[k] * jt[k] * r[k];
    }
    double hr = h_oo, gr = g_o;
    for (int p = 0; p < pairs; ++p) {
      if (h_pp[p] <= 0) continue;
      hr -= h_op[p] * h_op[p] / h_pp[p];
      gr -= h_op[p] * g_p[p] / h_pp[p];
    }
    if (!(hr > 0)) return out;
    h_oo_reduced = hr;
    const double d_o = -gr / hr;
    o += d_o;
    for (int p = 0; p < pairs; ++p)
      if (h_pp[p] > 0) tz[p] += -(g_p[p] + h_op[p] * d_o) / h_pp[p];
    if (std::abs(d_o) < 1e-5 && iter >= 2) break;
  }
  out.offset_px = o;
  out.sigma_px = sigma / std::sqrt(h_oo_reduced);
  out.valid = out.samples >= min_samples && out.sigma_px <= max_sigma_px && std::isfinite(o);
  return out;
}

std::vector<DisparityPairSample> CollectDisparitySamples(const SlamMap& map, const RectifiedStereo& cam,
                                                         const std::vector<int>& keyframes, int* num_pairs) {
  const std::set<int> use(keyframes.begin(), keyframes.end());
  std::map<std::pair<int, int>, int> pair_index;
  std::vector<DisparityPairSample> out;
  std::vector<std::pair<int, int>> obs;  // (keyframe, feature), by keyframe id
  for (const MapPoint& p : map.points) {
    if (p.bad || p.observations.size() < 2) continue;
    obs.clear();
    for (const auto& [k, f] : p.observations)
      if (use.count(k) && !map.keyframes[k].bad && map.keyframes[k].features.u_right[f] >= 0) obs.emplace_back(k, f);
    for (size_t m = 1; m < obs.size(); ++m) {
      const Keyframe& ki = map.keyframes[obs[m - 1].first];
      const Keyframe& kj = map.keyframes[obs[m].first];
      const cv::KeyPoint& kpi = ki.features.keypoints[obs[m - 1].second];
      const cv::KeyPoint& kpj = kj.features.keypoints[obs[m].second];
      DisparityPairSample s;
      s.d_i = kpi.pt.x - ki.features.u_right[obs[m - 1].second];
      s.d_j = kpj.pt.x - kj.features.u_right[obs[m].second];
      const Eigen::Vector3d ray_i((kpi.pt.x - cam.cx_px) / cam.f_px, (kpi.pt.y - cam.cy_px) / cam.f_px, 1.0);
      s.a = (kj.T_cam_world.linear() * ki.T_cam_world.linear().transpose() * ray_i).z();
      const auto key = std::make_pair(ki.id, kj.id);
      auto it = pair_index.find(key);
      if (it == pair_index.end()) it = pair_index.emplace(key, static_cast<int>(pair_index.size())).first;
      s.pair = it->second;
      out.push_back(s);
    }
  }
  *num_pairs = static_cast<int>(pair_index.size());
  return out;
}

DisparityOffsetEstimate EstimateMapDisparityOffset(const SlamMap& map, const RectifiedStereo& camera) {
  std::vector<int> kfs;
  for (const Keyframe& kf : map.keyframes)
    if (!kf.bad) kfs.push_back(kf.id);
  int pairs = 0;
  const std::vector<DisparityPairSample> samples = CollectDisparitySamples(map, camera, kfs, &pairs);
  return EstimateDisparityOffset(samples, pairs, camera.bf());
}

bool KeepsStereoMatch(double u, double u_right) { return u - u_right > 0.05 && u_right >= 0; }

void AddDisparityOffset(StereoFeatures* f, const RectifiedStereo& camera, double offset_px) {
  for (size_t i = 0; i < f->size(); ++i) {
    if (f->u_right[i] < 0) continue;
    const double ur = f->u_right[i] - offset_px, d = f->keypoints[i].pt.x - ur;
    if (KeepsStereoMatch(f->keypoints[i].pt.x, ur)) {
      f->u_right[i] = static_cast<float>(ur);
      f->depth_m[i] = static_cast<float>(camera.bf() / d);
    } else {
      f->u_right[i] = -1.f;
      f->depth_m[i] = -1.f;
    }
  }
}

}  // namespace rs
