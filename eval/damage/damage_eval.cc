#include "eval/damage/damage_eval.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <tuple>

namespace rs {

void PixelMetrics::Add(const PixelMetrics& o) {
  tp += o.tp, fp += o.fp, fn += o.fn, tn += o.tn;
  Finish();
}

void PixelMetrics::Finish() {
  precision = tp + fp > 0 ? double(tp) / double(tp + fp) : 0.0;
  recall = tp + fn > 0 ? double(tp) / double(tp + fn) : 0.0;
  f1 = 2 * tp + fp + fn > 0 ? 2.0 * double(tp) / double(2 * tp + fp + fn) : 0.0;
  iou = tp + fp + fn > 0 ? double(tp) / double(tp + fp + fn) : 0.0;
}

PixelMetrics ComparePixels(const cv::Mat& predicted, const cv::Mat& truth, const cv::Mat& ignore) {
  if (predicted.size() != truth.size() || predicted.channels() != 1 || truth.channels() != 1)
    throw std::invalid_argument("ComparePixels: masks must be single-channel and of equal size");
  if (!ignore.empty() && (ignore.size() != truth.size() || ignore.type() != CV_8UC1))
    throw std::invalid_argument("ComparePixels: ignore mask must be CV_8U of the masks' size");
  const cv::Mat p = predicted != 0, t = truth != 0;
  PixelMetrics m;
  for (int v = 0; v < p.rows; ++v) {
    const uchar *pr = p.ptr<uchar>(v), *tr = t.ptr<uchar>(v);
    const uchar* ig = ignore.empty() ? nullptr : ignore.ptr<uchar>(v);
    for (int u = 0; u < p.cols; ++u) {
      if (ig && ig[u]) continue;
      if (pr[u] && tr[u])
        ++m.tp;
      else if (pr[u])
        ++m.fp;
      else if (tr[u])
        ++m.fn;
      else
        ++m.tn;
    }
  }
  m.Finish();
  return m;
}

InstanceEvaluation MatchInstances(const cv::Mat& predicted_labels, const cv::Mat& truth_labels,
                                  const std::vector<DamageInstance>& predicted, const std::vector<TruthInstance>& truth,
                                  double min_iou) {
  if (predicted_labels.size() != truth_labels.size())
    throw std::invalid_argument("MatchInstances: label images differ in size");
  cv::Mat p, t;
  predicted_labels.convertTo(p, CV_32S);
  truth_labels.convertTo(t, CV_32S);
  std::map<int, long long> area_p, area_t;
  std::map<std::pair<int, int>, long long> inter;
  for (int v = 0; v < p.rows; ++v) {
    const int *pr = p.ptr<int>(v), *tr = t.ptr<int>(v);
    for (int u = 0; u < p.cols; ++u) {
      if (pr[u]) ++area_p[pr[u]];
      if (tr[u]) ++area_t[tr[u]];
      if (pr[u] && tr[u]) ++inter[{pr[u], tr[u]}];
    }
  }
  std::vector<std::tuple<double, int, int>> pairs;
  for (const auto& [key, n] : inter) {
    const double iou = double(n) / double(area_p[key.first] + area_t[key.second] - n);
    if (iou >= min_iou) pairs.emplace_back(iou, key.first, key.second);
  }
  std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return std::get<0>(a) > std::get<0>(b); });
  InstanceEvaluation e;
  e.predicted = static_cast<int>(area_p.size());
  e.truth = static_cast<int>(area_t.size());
  std::map<int, bool> used_p, used_t;
  for (const auto& [iou, pid, tid] : pairs) {
    if (used_p[pid] || used_t[tid]) continue;
    used_p[pid] = used_t[tid] = true;
    InstanceMatch m;
    m.predicted_id = pid, m.truth_id = tid, m.iou = iou;
    auto pi = std::find_if(predicted.begin(), predicted.end(), [&](const DamageInstance& d) { return d.id == pid; });
    auto ti = std::find_if(truth.begin(), truth.end(), [&](const TruthInstance& d) { return d.id == tid; });
    if (pi != predicted.end() && ti != truth.end()) {
      m.area_error_m2 = pi->area_m2 - ti->area_m2;
      m.max_depth_error_m = pi->max_depth_m - ti->max_depth_m;
      m.volume_error_m3 = pi->volume_m3 - ti->volume_m3;
    }
    e.matches.push_back(m);
  }
  const int tp = static_cast<int>(e.matches.size());
  e.false_positives = e.predicted - tp;
  e.false_negatives = e.truth - tp;
  e.precision = e.predicted ? double(tp) / e.predicted : 0.0;
  e.recall = e.truth ? double(tp) / e.truth : 0.0;
  e.f1 = e.predicted + e.truth ? 2.0 * tp / double(e.predicted + e.truth) : 0.0;
  return e;
}

}  // namespace rs
