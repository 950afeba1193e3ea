#include "eval/damage/sim_segment_eval.h"

#include "eval/damage/sim_truth.h"
#include "formats/geojson/geojson.h"
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
  for (const auto& f : geojson::ReadFeatureCollection(path).features) {
    const TruthFeatureKey key = ReadTruthFeatureKey(f.properties, path);
    (key.type == "pothole" ? k.potholes : k.others).insert(key.id);
    const auto num = [&](const char* name) {
      return f.properties.contains(name) && f.properties[name].is_number() ? f.properties[name].get<double>() : 0.0;
    };
    if (key.type == "pothole") k.size[key.id] = {num("max_depth_m"), num("mean_diameter_m")};
  }
  return k;
}

}  // namespace

SimSegmentEvaluation EvaluateSimulatedSegmentation(const std::filesystem::path& dir, const SimSegmentEvalOptions& o) {
  if (o.frame_step < 1 || o.max_frames < 0)
    throw std::invalid_argument("EvaluateSimulatedSegmentation: frame_step >= 1, max_frames >= 0");
  o.disparity.Check();
  DamageOptions damage = o.damage;
  damage.crack.enabled = false;
  damage.Check();
  const SimSurveyTruth survey = ReadSimSurveyTruth(dir);
  const RectifiedStereo& g = survey.geometry;
  const TruthKinds kinds = ReadTruthKinds(dir / "truth/damages.geojson");
  SimSegmentEvaluation r;
  for (size_t k = 0; k < survey.frames.size(); k += o.frame_step) {
    if (o.max_frames > 0 && r.frames >= o.max_frames) break;
    const SimFrameTruth frame = ReadSimFrame(survey, k);
    DisparityParams dp = o.disparity;
    dp.camera_focal_px = g.f_px;  // as the disparity stage takes it from the calibration
    const DisparityResult dr = ComputeDisparity(frame.left, ReadSimRightImage(survey, k), dp);
    ++r.frames;
    // Scored range: the damage stage's, from the truth disparity (what the frame can measure).
    const double range = AnalysedRangeM(g, damage, NearestDepthM(frame.truth_disparity_px, g));
    const double d_min = std::isfinite(range) && range > 0 ? g.f_px * g.baseline_m / range : 0.0;
    cv::Mat truth(frame.masks.size(), CV_8U), ignore(frame.masks.size(), CV_8U);
    for (int v = 0; v < truth.rows; ++v) {
      const uint16_t* m = frame.masks.ptr<uint16_t>(v);
      const float* d = frame.truth_disparity_px.ptr<float>(v);
      uchar* t = truth.ptr<uchar>(v);
      uchar* ig = ignore.ptr<uchar>(v);
      for (int u = 0; u < truth.cols; ++u) {
        t[u] = kinds.potholes.count(m[u]) ? 255 : 0;
        ig[u] = (m[u] != 0 && !t[u]) || !(d[u] > d_min) ? 255 : 0;
      }
    }
    const bool has_pothole = cv::countNonZero(truth & (ignore == 0)) > 0;
    TransformedSegmentation seg;
    seg.labels = cv::Mat::zeros(truth.size(), CV_16U);
    if (!dr.transformed.empty() && cv::countNonZero(dr.transformed > 0) >= 100)
      seg = SegmentTransformedDisparity(dr.transformed, cv::Mat(), damage);
    const cv::Mat& labels = seg.labels;
    if (!o.debug_dir.empty()) {
      std::filesystem::create_directories(o.debug_dir);
      cv::Mat overlay = RenderOverlay(frame.left, labels, seg.instances);
      std::vector<std::vector<cv::Point>> contours;
      cv::findContours(truth.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
      cv::drawContours(overlay, contours, -1, cv::Scalar(0, 255, 0), 2);
      cv::imwrite((o.debug_dir / (survey.frames[k] + ".png")).string(), overlay);
    }
    if (o.potholes_only && !has_pothole) {  // a frame of intact road must stay empty
      if (!seg.instances.empty()) {
        ++r.false_frames;
        r.false_frame_names.push_back(survey.frames[k]);
      }
      continue;
    }
    SimSegmentFrame f;
    f.frame = survey.frames[k];
    f.instances = static_cast<int>(seg.instances.size());
    f.pixels = ComparePixels(labels, truth, ignore);
    // Per truth pothole in range: the share of its scored pixels found.
    std::map<int, std::pair<long long, long long>> found;  // id -> (found, scored)
    for (int v = 0; v < truth.rows; ++v) {
      const uint16_t* m = frame.masks.ptr<uint16_t>(v);
      const uint16_t* l = labels.ptr<uint16_t>(v);
      const uchar* t = truth.ptr<uchar>(v);
      const uchar* ig = ignore.ptr<uchar>(v);
      for (int u = 0; u < truth.cols; ++u)
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
  return r;
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
