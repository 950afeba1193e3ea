#include "stages/damage/damage_pipeline.h"

#include "stages/damage/cracks/cracks.h"
#include "stages/damage/output/damage_output.h"
#include "stages/damage/measure/floor_visibility.h"
#include "stages/damage/noise/image_edges.h"
#include "stages/damage/measure/measure.h"
#include "survey/stats/order_statistic.h"
#include "stages/damage/noise/relief_noise.h"
#include "stages/damage/road/relief_smooth.h"
#include "stages/damage/road/road_islands.h"
#include "stages/damage/grade/severity.h"
#include "stages/damage/measure/sharp_disparity.h"
#include "stages/damage/noise/two_sided_noise.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <limits>
#include <string>
#include <stdexcept>
#include <vector>

namespace rs {
namespace {

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Appends crack instances to `labels`/`instances` with ids after the depressions.
// Each crack is written within its bounding box only.
void AddCracks(const CrackDetection& cracks, cv::Mat& labels, std::vector<DamageInstance>& instances) {
  const int base = instances.empty() ? 0 : instances.back().id;
  const std::vector<cv::Rect> boxes = LabelBoxes(cracks.labels);
  for (DamageInstance d : cracks.instances) {
    if (base + d.id > 65535) break;
    const int old_id = d.id;
    d.id = base + old_id;
    if (old_id < static_cast<int>(boxes.size()) && !boxes[old_id].empty()) {
      const cv::Rect& b = boxes[old_id];
      cv::Mat sub = labels(b);
      sub.setTo(d.id, (cracks.labels(b) == old_id) & (sub == 0));
    }
    instances.push_back(std::move(d));
  }
}

}  // namespace

void DamageOptions::Check() const {
  road.Check();
  segment.Check();
  crack.Check();
  measure.Check();
  severity.Check();
}

double AnalysedRangeM(const RectifiedStereo& g, const DamageOptions& o, double nearest_depth_m) {
  if (!(o.road.max_depth_sigma_m > 0)) return std::numeric_limits<double>::infinity();
  const double sigma_range = std::sqrt(o.road.max_depth_sigma_m * g.f_px * g.baseline_m / o.measure.sigma_disparity_px);
  return std::max(sigma_range, o.road.min_range_factor * nearest_depth_m);
}

double NearestDepthM(const cv::Mat& disparity_px, const RectifiedStereo& g) {
  std::vector<float> samples;
  for (int y = 0; y < disparity_px.rows; y += 4) {
    const float* row = disparity_px.ptr<float>(y);
    for (int x = 0; x < disparity_px.cols; x += 4)
      if (row[x] > 0 && std::isfinite(row[x])) samples.push_back(row[x]);
  }
  if (samples.empty()) return 0;
  return g.f_px * g.baseline_m / KthSmallestInPlace(samples, QuantileRankDown(0.98, samples.size()));
}

FrameDamage DetectDamage(const cv::Mat& input_disparity_px, const cv::Mat& left_image, const RectifiedStereo& g,
                         const DamageOptions& o, const cv::Mat& sharp_disparity_px) {
  o.Check();
  if (!left_image.empty() && left_image.size() != input_disparity_px.size())
    throw std::invalid_argument("DetectDamage: left image and disparity differ in size");
  if (!g.Valid()) throw std::invalid_argument("DetectDamage: stereo geometry needs f > 0 and baseline > 0");
  if (input_disparity_px.type() != CV_32FC1) throw std::invalid_argument("DetectDamage: disparity must be CV_32FC1");
  FrameDamage f;
  auto t0 = std::chrono::steady_clock::now();
  // The image-only work (paint-edge mask, crack black-hat response) runs alongside the road
  // model, whose fit is serial. Declared after its outputs: on an exception the group is
  // cancelled and waited for before they go.
  const bool want_edges = o.segment.noise_cell_px > 0 && !left_image.empty() && o.segment.edge_min_gradient > 0;
  const bool want_cracks = o.crack.enabled && !left_image.empty();
  cv::Mat edges, crack_response, pixel_size;
  tbb::task_group image_work;
  image_work.run([&] {
    if (want_edges) edges = StrongEdgeMask(left_image, o.segment.edge_min_gradient, o.segment.edge_margin_px);
  });
  cv::Mat disparity_px;  // a new image: the caller's disparity is not changed
  f.analysed_range_m = AnalysedRangeM(g, o, NearestDepthM(input_disparity_px, g));
  if (const double z_max = f.analysed_range_m; std::isfinite(z_max))  // beyond: set to 0 (invalid)
    cv::threshold(input_disparity_px, disparity_px, g.f_px * g.baseline_m / z_max, 0, cv::THRESH_TOZERO);
  else
    disparity_px = input_disparity_px;
  f.surface = FitRoadSurface(disparity_px, g, o.road);
  const RoadRelief evaluated = EvaluateRoadModel(disparity_px, g, f.surface, o.road);
  f.relief = FinishRoadRelief(evaluated, disparity_px, g, f.surface, o.road);  // `evaluated` kept for the refinement
  f.ms_road = MsSince(t0);

  t0 = std::chrono::steady_clock::now();
  image_work.wait();  // rethrows the image work's exception, if any
  ReliefImage relief{f.relief.transformed_disparity_px, f.relief.valid_mask & (f.relief.obstacle_mask == 0),
                     RoadRowElongation(disparity_px.rows, g, f.surface.normal)};
  const cv::Mat area = PixelAreaOnRoad(f.relief, g, f.surface);
  cv::sqrt(area, pixel_size);  // metres per pixel on the road (NaN off-road)
  // Patches of "road" cut off from the road by obstacle and unmatched pixels are mismatches on
  // an obstacle (road_islands.h): no damage is found on them.
  const cv::Mat islands = RoadIslandMask(relief.valid, area, o.road.min_region_m2);
  const bool has_islands = cv::countNonZero(islands) > 0;
  // The crack response needs the pixel sizes (element sized on the road): alongside the segmentation.
  if (want_cracks) image_work.run([&] { crack_response = CrackResponse(left_image, o.crack, pixel_size); });
  const ReliefScale scale = EstimateReliefScale(relief);
  // Seeds must be significant against the noise where they lie (LocalReliefNoise, never below
  // the frame's σ). Pixels next to strong image steps (paint edges) form their own noise class,
  // estimated from those pixels alone: where the matcher fails there (0.3-1 px) they can neither
  // seed a depression nor carry one along the paint (they grow only as deep as they seed), where
  // it does not (the truth disparity) they are road like any other.
  cv::Mat noise, road_noise, reliable;
  if (o.segment.noise_cell_px > 0) {
    // A new image: assigned to a copy of relief.valid's header, the expression was written into
    // relief.valid itself and cleared every edge pixel from the segmentation (a pothole under an
    // edge line: car, truth disparity, IoU 0.53; docs/stages/damage.md "Paint edges").
    reliable = edges.empty() ? relief.valid : cv::Mat(relief.valid & (edges == 0));
    // Road samples beyond 40 frame σ above the road are structure (the smoothed fringe of an
    // obstacle, the model bent beside it), not matching noise; at paint edges they are the noise.
    noise = LocalReliefNoise(relief.value, reliable, scale.road_level, o.segment.noise_cell_px, scale.sigma, 40.0);
    road_noise = noise;  // shared until the edge class changes `noise`
    if (!edges.empty() && cv::countNonZero(edges) > 0) {
      const cv::Mat edge_noise =
          LocalReliefNoise(relief.value, relief.valid & edges, scale.road_level, o.segment.noise_cell_px, scale.sigma);
      cv::Mat merged(noise.size(), CV_32F);  // `noise` may be road_noise: not changed
      tbb::parallel_for(0, noise.rows, [&](int v) {
        const float* n = noise.ptr<float>(v);
        const float* en = edge_noise.ptr<float>(v);
        const uchar* e = edges.ptr<uchar>(v);
        float* m = merged.ptr<float>(v);
        for (int u = 0; u < noise.cols; ++u) m[u] = e[u] ? std::max(n[u], en[u]) : n[u];
      });
      noise = merged;
    }
  }
  const DepressionSegmentation seg =
      SegmentDepressions(relief, o.segment, area, scale, noise, noise.empty() ? cv::Mat() : edges);
  f.labels = seg.labels;
  // Obstacle pixels were measured above the road: never damage. The segmentation sees them only
  // as pixels without relief, like stereo dropouts, and absorbs such patches into a depression
  // they border: a parked car beside a false depression became a 15 m² "pothole" (obstacles
  // preset, truth disparity).
  f.labels.setTo(0, f.relief.obstacle_mask);
  // Islands likewise, after the segmentation (the noise maps keep them, as before): a
  // depression mostly on one goes whole, with the unmatched pixels it took in.
  if (has_islands) RemoveIslandLabels(f.labels, islands, relief.valid);
  f.threshold_sigma = seg.threshold_sigma;
  if (o.road.local_cell_px > 0 && seg.count > 0) {
    // The local road correction, recomputed without the found depressions (grown by half a
    // cell), no longer leans into large shallow damage: depths and rims are measured on it.
    // Dilated at quarter resolution: a 49×49 disk at full resolution costs more than the
    // rest of the segmentation, and the cell medians need no pixel accuracy.
    const int r = std::max(1, o.road.local_cell_px / 8);
    cv::Mat small, exclude;
    cv::resize(f.labels != 0, small, cv::Size((f.labels.cols + 3) / 4, (f.labels.rows + 3) / 4), 0, 0,
               cv::INTER_AREA);
    cv::dilate(small > 0, small, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
    cv::resize(small, exclude, f.labels.size(), 0, 0, cv::INTER_NEAREST);
    RefineRoadRelief(f.relief, evaluated, disparity_px, g, f.surface, o.road, exclude);
  }
  ExtendToRim(f.labels, f.relief, o.segment.rim_depth_m, o.segment.rim_depth_fraction,
              o.segment.rim_ring_mean ? o.road.relief_smooth_px : 0, relief.row_elongation,
              evaluated.depth_below_mm);
  // The pothole rule's noise: beside a kerb the road rises where the model does not follow,
  // which is not matching noise (TwoSidedReliefNoise); on each depression its spread below
  // leaves that depression out (its own walls are not the road's noise). The seeds keep the
  // one-sided noise.
  if (!road_noise.empty() && o.measure.pothole_min_noise_sigma > 0 && o.measure.pothole_noise_two_sided)
    road_noise = TwoSidedReliefNoise(road_noise, relief.value, reliable, scale.road_level, o.segment.noise_cell_px,
                                     scale.sigma, 40.0, 2.0, f.labels);
  f.ms_segment = MsSince(t0);

  t0 = std::chrono::steady_clock::now();
  cv::Mat measure_noise = o.measure.pothole_min_noise_sigma > 0 ? road_noise : cv::Mat();
  if (!measure_noise.empty() && o.measure.pothole_min_spike_ratio > 0) {
    // The spike rule folded into the noise rule (measured over the instance as one mean):
    // max depth ≥ min_noise_sigma · max(noise, spikes · spike_ratio / min_noise_sigma). Edge
    // pixels are included: wrong winners gather there.
    const cv::Mat spikes = LocalReliefSpikes(relief.value, relief.valid, scale.road_level, o.segment.noise_cell_px,
                                             scale.sigma, 40.0, o.measure.spike_quantile);
    // max(road_noise, spikes · k) in one pass (as cv::max of the scaled copy: OpenCV scales a
    // float image by the float factor, one rounding).
    const float k = static_cast<float>(o.measure.pothole_min_spike_ratio / o.measure.pothole_min_noise_sigma);
    measure_noise = cv::Mat(road_noise.size(), CV_32F);  // a new image: road_noise is kept
    tbb::parallel_for(0, road_noise.rows, [&](int v) {
      const float* rn = road_noise.ptr<float>(v);
      const float* sp = spikes.ptr<float>(v);
      float* m = measure_noise.ptr<float>(v);
      for (int u = 0; u < road_noise.cols; ++u) m[u] = std::max(rn[u], sp[u] * k);
    });
  }
  // The volume is summed on the disparity stage's sharp image where given (sharp_disparity.h).
  const cv::Mat sharp_depth_mm =
      sharp_disparity_px.empty()
          ? cv::Mat()
          : SharpDepthBelowMm(sharp_disparity_px, disparity_px, f.labels, g, f.surface, f.relief.correction_mm);
  f.instances = MeasureDepressions(f.labels, f.relief, g, f.surface, o.measure, measure_noise, sharp_depth_mm);
  // Oblique views: may the near rim hide the floor (depth and volume then lower bounds)?
  AnalyseFloorVisibility(f.instances, f.labels, f.relief, g, f.surface, o.measure);
  f.ms_measure = MsSince(t0);

  if (o.crack.enabled && !left_image.empty()) {
    t0 = std::chrono::steady_clock::now();
    image_work.wait();
    // relief.valid: the road mask (valid, not obstacle), here without its islands; RefineRoadRelief changes neither mask.
    const cv::Mat crack_road = has_islands ? cv::Mat(relief.valid & (islands == 0)) : relief.valid;
    const CrackDetection cracks = DetectCracks(left_image, crack_road, f.labels != 0, pixel_size, o.crack, crack_response);
    AddCracks(cracks, f.labels, f.instances);
    f.ms_cracks = MsSince(t0);
  }
  const std::vector<cv::Rect> boxes = LabelBoxes(f.labels);
  for (DamageInstance& d : f.instances) {
    if (d.type == DamageType::kCrack && d.id < static_cast<int>(boxes.size()) && !boxes[d.id].empty()) {
      const cv::Rect& b = boxes[d.id];
      d.range_m = cv::mean(f.relief.road_depth_m(b), f.labels(b) == d.id)[0];
      d.sigma_depth_m = StereoDepthSigma(d.range_m, o.measure.sigma_disparity_px, g);
    }
    GradeInstance(d, o.severity);
  }
  return f;
}

TransformedSegmentation SegmentTransformedDisparity(const cv::Mat& transformed, const cv::Mat& left_image,
                                                    const DamageOptions& o, std::optional<ReliefScale> scale) {
  o.Check();
  if (!left_image.empty() && left_image.size() != transformed.size())
    throw std::invalid_argument("SegmentTransformedDisparity: left image and disparity differ in size");
  const ReliefImage relief = ToRelief(transformed);
  const DepressionSegmentation seg = SegmentDepressions(relief, o.segment, cv::Mat(), scale);
  TransformedSegmentation out;
  out.labels = seg.labels;
  out.scale = seg.scale;
  out.threshold_sigma = seg.threshold_sigma;
  for (int id = 1; id <= seg.count; ++id) {
    DamageInstance d;
    d.id = id;
    d.type = DamageType::kOther;  // depth unknown in metres: cannot tell a pothole by the tables
    d.pixel_count = cv::countNonZero(seg.labels == id);
    d.outline_px = OutlineOf(seg.labels, id);
    // Confidence: mean depth of the region in road σ, relative to the threshold.
    const double mean_z = (cv::mean(relief.value, (seg.labels == id) & relief.valid)[0] - seg.scale.road_level) /
                          seg.scale.sigma;
    d.confidence = std::clamp(-mean_z / (2.0 * seg.threshold_sigma), 0.0, 1.0);
    d.astm.rule = "ASTM D6433: no metric depth from a transformed disparity -> not graded";
    d.fhwa.rule = "FHWA LTPP: no metric depth from a transformed disparity -> not graded";
    d.intervention_rule = "no metric measurements -> not assessed";
    out.instances.push_back(std::move(d));
  }
  if (o.crack.enabled && !left_image.empty()) {
    const CrackDetection cracks = DetectCracks(left_image, relief.valid, out.labels != 0, cv::Mat(), o.crack);
    AddCracks(cracks, out.labels, out.instances);
  }
  return out;
}

}  // namespace rs
