#include "eval/damage/sim_segment_eval.h"

#include "eval/damage/sim_truth.h"
#include "stages/damage/damage_pipeline.h"
#include "stages/damage/output/damage_output.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <map>
#include <set>
#include <stdexcept>

namespace rs {
namespace {

// Truth ids by kind: potholes, and every other damage (left out of the score).
struct TruthKinds {
  std::set<int> potholes, others;
  std::map<int, std::pair<double, double>> size;  ///< pothole id -> (max depth m, mean diameter m)
};

TruthKinds ReadTruthKinds(const std::filesystem::path& path) {
  TruthKinds k;
  for (const auto& [id, d] : ReadTruthDamages(path)) {
    (d.type == "pothole" ? k.potholes : k.others).insert(id);
    if (d.type == "pothole") k.size[id] = {d.max_depth_m, d.mean_diameter_m};
  }
  return k;
}

}  // namespace

namespace {

// One frame ready to be segmented: its transformed disparity, the truth pothole mask and the
// pixels left out of the score.
struct PreparedFrame {
  std::string name;
  cv::Mat left, transformed, masks, truth, ignore;
  bool has_pothole = false;
};

PreparedFrame PrepareFrame(const SimSurveyTruth& survey, size_t k, const TruthKinds& kinds,
                           const SimSegmentEvalOptions& o, const DamageOptions& damage) {
  const RectifiedStereo& g = survey.geometry;
  const SimFrameTruth frame = ReadSimFrame(survey, k);
  DisparityParams dp = o.disparity;
  dp.camera_focal_px = g.f_px;  // as the disparity stage takes it from the calibration
  PreparedFrame p;
  p.name = survey.frames[k];
  p.left = frame.left;
  p.masks = frame.masks;
  p.transformed = ComputeDisparity(frame.left, ReadSimRightImage(survey, k), dp).transformed;
  // Scored range: the damage stage's, from the truth disparity (what the frame can measure).
  const double range = AnalysedRangeM(g, damage, NearestDepthM(frame.truth_disparity_px, g));
  const double d_min = std::isfinite(range) && range > 0 ? g.f_px * g.baseline_m / range : 0.0;
  p.truth.create(frame.masks.size(), CV_8U);
  p.ignore.create(frame.masks.size(), CV_8U);
  for (int v = 0; v < p.truth.rows; ++v) {
    const uint16_t* m = frame.masks.ptr<uint16_t>(v);
    const float* d = frame.truth_disparity_px.ptr<float>(v);
    uchar* t = p.truth.ptr<uchar>(v);
    uchar* ig = p.ignore.ptr<uchar>(v);
    for (int u = 0; u < p.truth.cols; ++u) {
      t[u] = kinds.potholes.count(m[u]) ? 255 : 0;
      ig[u] = (m[u] != 0 && !t[u]) || !(d[u] > d_min) ? 255 : 0;
    }
  }
  p.has_pothole = cv::countNonZero(p.truth & (p.ignore == 0)) > 0;
  return p;
}

// Segments one prepared frame with `damage` and adds its score to `r`; `draw`: writes the debug
// overlay (when options ask for one).
void ScoreFrame(const PreparedFrame& p, const TruthKinds& kinds, const DamageOptions& damage,
                const SimSegmentEvalOptions& o, bool draw, SimSegmentEvaluation& r) {
  ++r.frames;
  TransformedSegmentation seg;
  seg.labels = cv::Mat::zeros(p.truth.size(), CV_16U);
  if (!p.transformed.empty() && cv::countNonZero(p.transformed > 0) >= 100)
    seg = SegmentTransformedDisparity(p.transformed, cv::Mat(), damage);
  const cv::Mat& labels = seg.labels;
  if (draw && !o.debug_dir.empty()) {
    std::filesystem::create_directories(o.debug_dir);
    cv::Mat overlay = RenderOverlay(p.left, labels, seg.instances);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(p.truth.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    cv::drawContours(overlay, contours, -1, cv::Scalar(0, 255, 0), 2);
    cv::imwrite((o.debug_dir / (p.name + ".png")).string(), overlay);
  }
  if (o.potholes_only && !p.has_pothole) {  // a frame of intact road must stay empty
    if (!seg.instances.empty()) {
      ++r.false_frames;
      r.false_frame_names.push_back(p.name);
    }
    return;
  }
  SimSegmentFrame f;
  f.frame = p.name;
  f.instances = static_cast<int>(seg.instances.size());
  f.pixels = ComparePixels(labels, p.truth, p.ignore);
  // Per truth pothole in range: the share of its scored pixels found.
  std::map<int, std::pair<long long, long long>> found;  // id -> (found, scored)
  for (int v = 0; v < p.truth.rows; ++v) {
    const uint16_t* m = p.masks.ptr<uint16_t>(v);
    const uint16_t* l = labels.ptr<uint16_t>(v);
    const uchar* t = p.truth.ptr<uchar>(v);
    const uchar* ig = p.ignore.ptr<uchar>(v);
    for (int u = 0; u < p.truth.cols; ++u)
      if (t[u] && !ig[u]) {
        auto& c = found[m[u]];
        ++c.second;
        c.first += l[u] != 0;
      }
  }
  for (const auto& [id, c] : found) {
    if (c.second < 200) continue;  // a sliver at the range limit or the border
    const double share = double(c.first) / double(c.second);
    const auto [depth, diameter] = kinds.size.count(id) ? kinds.size.at(id) : std::pair<double, double>{0, 0};
    (share >= 0.5 ? r.potholes_found : r.potholes_missed)
        .push_back(fmt::format("{} id {}: {:.0f} mm deep, {:.2f} m across, {} px, {:.0f} % found", f.frame, id,
                               1000 * depth, diameter, c.second, 100 * share));
  }
  r.pixels.Add(f.pixels);
  ++r.frames_scored;
  r.per_frame.push_back(f);
}

}  // namespace

std::vector<SimSegmentEvaluation> EvaluateSimulatedSegmentation(const std::filesystem::path& dir,
                                                                const SimSegmentEvalOptions& o,
                                                                const std::vector<SegmentOptions>& variants) {
  if (o.frame_step < 1 || o.max_frames < 0)
    throw std::invalid_argument("EvaluateSimulatedSegmentation: frame_step >= 1, max_frames >= 0");
  o.disparity.Check();
  std::vector<DamageOptions> damages;
  for (const SegmentOptions& v : variants) {
    DamageOptions d = o.damage;
    d.segment = v;
    d.crack.enabled = false;
    d.Check();
    damages.push_back(d);
  }
  const SimSurveyTruth survey = ReadSimSurveyTruth(dir);
  const TruthKinds kinds = ReadTruthKinds(dir / "truth/damages.geojson");
  std::vector<SimSegmentEvaluation> out(variants.size());
  int frames = 0;
  for (size_t k = 0; k < survey.frames.size(); k += o.frame_step) {
    if (o.max_frames > 0 && frames >= o.max_frames) break;
    ++frames;
    // The analysed range does not depend on the segmentation options: the first variant's.
    const PreparedFrame p = PrepareFrame(survey, k, kinds, o, damages.empty() ? o.damage : damages.front());
    for (size_t i = 0; i < damages.size(); ++i) ScoreFrame(p, kinds, damages[i], o, i + 1 == damages.size(), out[i]);
  }
  return out;
}

SimSegmentEvaluation EvaluateSimulatedSegmentation(const std::filesystem::path& dir, const SimSegmentEvalOptions& o) {
  return EvaluateSimulatedSegmentation(dir, o, {o.damage.segment}).front();
}

std::string SimSegmentEvaluation::Report() const {
  std::string s = fmt::format(
      "frames {} (scored {}, without a pothole but with an instance {})\npixels pooled: P {:.3f} R {:.3f} "
      "F1 {:.3f} IoU {:.3f}\n",
      frames, frames_scored, false_frames, pixels.precision, pixels.recall, pixels.f1, pixels.iou);
  s += fmt::format("potholes (frame, id) at least half found: {}, missed: {}\n", potholes_found.size(),
                   potholes_missed.size());
  for (const std::string& m : potholes_missed) s += "  missed " + m + "\n";
  if (!false_frame_names.empty()) s += "instances without a pothole in range: " + fmt::format("{}", fmt::join(false_frame_names, " ")) + "\n";
  for (const SimSegmentFrame& f : per_frame)
    s += fmt::format("  {}: {} instances, P {:.3f} R {:.3f} F1 {:.3f}\n", f.frame, f.instances, f.pixels.precision,
                     f.pixels.recall, f.pixels.f1);
  return s;
}

}  // namespace rs
