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
#include "stages/damage/segment/local_level.h"
#include "stages/damage/noise/two_sided_noise.h"
#include "survey/elapsed.h"

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

namespace {

// Per-frame state of DetectDamage: its inputs, what each pass hands on to the next, the result.
struct DamageFrame {
  DamageFrame(const cv::Mat& input_disparity_px, const cv::Mat& left_image, const RectifiedStereo& g,
              const DamageOptions& o, const cv::Mat& sharp_disparity_px)
      : input_disparity_px(input_disparity_px),
        left_image(left_image),
        g(g),
        o(o),
        sharp_disparity_px(sharp_disparity_px),
        want_edges(o.segment.noise_cell_px > 0 && !left_image.empty() && o.segment.edge_min_gradient > 0),
        want_cracks(o.crack.enabled && !left_image.empty()) {}

  const cv::Mat& input_disparity_px;
  const cv::Mat& left_image;
  const RectifiedStereo& g;
  const DamageOptions& o;
  const cv::Mat& sharp_disparity_px;
  const bool want_edges;   ///< the paint-edge noise class applies
  const bool want_cracks;  ///< crack detection applies

  FrameDamage f;         ///< the result
  cv::Mat disparity_px;  ///< within the analysed range (a new image: the caller's disparity is not changed)
  RoadRelief evaluated;  ///< the road model's relief before FinishRoadRelief, kept for the refinement
  ReliefImage relief;    ///< the segmentation's input: transformed disparity on the road (valid, not obstacle)
  cv::Mat area;          ///< m² of road per pixel (NaN off-road)
  cv::Mat islands;       ///< road cut off from the road (road_islands.h)
  bool has_islands = false;
  ReliefScale scale;   ///< the frame's road level and σ
  cv::Mat reliable;    ///< road pixels off paint edges: the noise map's samples
  cv::Mat noise;       ///< the seeds' noise (paint edges their own class)
  cv::Mat road_noise;  ///< the pothole rule's noise (two-sided after the rim pass)
  DepressionSegmentation seg;
  cv::Mat measure_noise;  ///< the pothole rule's noise with the spike rule folded in
  // Written by the image work alongside the road model and the segmentation.
  cv::Mat edges, crack_response, pixel_size;
  // Declared last: on an exception it is destroyed first, cancelled and waited for before the
  // images it writes go.
  tbb::task_group image_work;
};

// The image-only work (paint-edge mask) starts alongside the road model, whose fit is serial;
// it is joined in "road mask".
void StartPaintEdges(DamageFrame& s) {
  s.image_work.run([&s] {
    if (s.want_edges) s.edges = StrongEdgeMask(s.left_image, s.o.segment.edge_min_gradient, s.o.segment.edge_margin_px);
  });
}

// Disparities beyond the analysed range set to 0 (invalid).
void LimitRange(DamageFrame& s) {
  s.f.analysed_range_m = AnalysedRangeM(s.g, s.o, NearestDepthM(s.input_disparity_px, s.g));
  if (const double z_max = s.f.analysed_range_m; std::isfinite(z_max))
    cv::threshold(s.input_disparity_px, s.disparity_px, s.g.f_px * s.g.baseline_m / z_max, 0, cv::THRESH_TOZERO);
  else
    s.disparity_px = s.input_disparity_px;
}

void FitRoad(DamageFrame& s) { s.f.surface = FitRoadSurface(s.disparity_px, s.g, s.o.road); }

void ComputeRelief(DamageFrame& s) {
  s.evaluated = EvaluateRoadModel(s.disparity_px, s.g, s.f.surface, s.o.road);
  s.f.relief = FinishRoadRelief(s.evaluated, s.disparity_px, s.g, s.f.surface, s.o.road);
}

// The road mask, the pixel sizes on the road and the road's islands; starts the crack response.
void PrepareRoadMask(DamageFrame& s) {
  s.image_work.wait();  // rethrows the image work's exception, if any
  s.relief = ReliefImage{s.f.relief.transformed_disparity_px, s.f.relief.valid_mask & (s.f.relief.obstacle_mask == 0),
                         RoadRowElongation(s.disparity_px.rows, s.g, s.f.surface.normal)};
  s.area = PixelAreaOnRoad(s.f.relief, s.g, s.f.surface);
  cv::sqrt(s.area, s.pixel_size);  // metres per pixel on the road (NaN off-road)
  // Patches of "road" cut off from the road by obstacle and unmatched pixels are mismatches on
  // an obstacle (road_islands.h): no damage is found on them.
  s.islands = RoadIslandMask(s.relief.valid, s.area, s.o.road.min_region_m2);
  s.has_islands = cv::countNonZero(s.islands) > 0;
  s.f.road_mask = s.has_islands ? cv::Mat(s.relief.valid & (s.islands == 0)) : s.relief.valid.clone();
  // The crack response needs the pixel sizes (element sized on the road): alongside the segmentation.
  if (s.want_cracks)
    s.image_work.run([&s] { s.crack_response = CrackResponse(s.left_image, s.o.crack, s.pixel_size); });
}

// Seeds must be significant against the noise where they lie (LocalReliefNoise, never below the
// frame's σ). Pixels next to strong image steps (paint edges) form their own noise class,
// estimated from those pixels alone: where the matcher fails there they can neither seed a
// depression nor carry one along the paint, where it does not they are road like any other.
void BuildNoiseMaps(DamageFrame& s) {
  s.scale = EstimateReliefScale(s.relief);
  const int cell_px = s.o.segment.noise_cell_px;
  if (cell_px <= 0) return;
  // A new image where edges are left out: relief.valid itself must not change.
  s.reliable = s.edges.empty() ? s.relief.valid : cv::Mat(s.relief.valid & (s.edges == 0));
  s.noise =
      LocalReliefNoise(s.relief.value, s.reliable, s.scale.road_level, cell_px, s.scale.sigma, kStructureSigmaRatio);
  s.road_noise = s.noise;  // shared until the edge class changes `noise`
  if (s.edges.empty() || cv::countNonZero(s.edges) == 0) return;
  const cv::Mat edge_noise =
      LocalReliefNoise(s.relief.value, s.relief.valid & s.edges, s.scale.road_level, cell_px, s.scale.sigma);
  cv::Mat merged(s.noise.size(), CV_32F);  // `noise` may be road_noise: not changed
  tbb::parallel_for(0, s.noise.rows, [&](int v) {
    const float* n = s.noise.ptr<float>(v);
    const float* en = edge_noise.ptr<float>(v);
    const uchar* e = s.edges.ptr<uchar>(v);
    float* m = merged.ptr<float>(v);
    for (int u = 0; u < s.noise.cols; ++u) m[u] = e[u] ? std::max(n[u], en[u]) : n[u];
  });
  s.noise = merged;
}

void Segment(DamageFrame& s) {
  s.seg = SegmentDepressions(s.relief, s.o.segment, s.area, s.scale, s.noise, s.noise.empty() ? cv::Mat() : s.edges);
  s.f.labels = s.seg.labels;
  s.f.threshold_sigma = s.seg.threshold_sigma;
}

// Obstacle pixels were measured above the road: never damage. The segmentation sees them only
// as pixels without relief and absorbs such patches into a depression they border. Islands
// likewise, after the segmentation (the noise maps keep them): a depression mostly on one goes
// whole, with the unmatched pixels it took in.
void RemoveObstacles(DamageFrame& s) {
  s.f.labels.setTo(0, s.f.relief.obstacle_mask);
  if (s.has_islands) RemoveIslandLabels(s.f.labels, s.islands, s.relief.valid);
}

// The local road correction, recomputed without the found depressions (grown by half a cell),
// no longer leans into large shallow damage: depths and rims are measured on it.
bool WantsRefinement(const DamageFrame& s) { return s.o.road.local_cell_px > 0 && s.seg.count > 0; }
void RefineRoad(DamageFrame& s) {
  // Dilated at quarter resolution: a full-resolution disk costs more than the rest of the
  // segmentation, and the cell medians need no pixel accuracy.
  constexpr int kScale = 4;
  const int r = std::max(1, s.o.road.local_cell_px / (2 * kScale));
  const cv::Mat& labels = s.f.labels;
  cv::Mat small, exclude;
  cv::resize(labels != 0, small, cv::Size((labels.cols + kScale - 1) / kScale, (labels.rows + kScale - 1) / kScale), 0,
             0, cv::INTER_AREA);
  cv::dilate(small > 0, small, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
  cv::resize(small, exclude, labels.size(), 0, 0, cv::INTER_NEAREST);
  RefineRoadRelief(s.f.relief, s.evaluated, s.disparity_px, s.g, s.f.surface, s.o.road, exclude);
}

void ExtendRims(DamageFrame& s) {
  const SegmentOptions& so = s.o.segment;
  ExtendToRim(s.f.labels, s.f.relief, so.rim_depth_m, so.rim_depth_fraction,
              so.rim_ring_mean ? s.o.road.relief_smooth_px : 0, s.relief.row_elongation, s.evaluated.depth_below_mm);
}

// The pothole rule's noise: beside a kerb the road rises where the model does not follow, which
// is not matching noise (TwoSidedReliefNoise); on each depression its spread below leaves that
// depression out (its own walls are not the road's noise). The seeds keep the one-sided noise.
// The spike rule is folded in (measured over the instance as one mean): max depth ≥
// min_noise_sigma · max(noise, spikes · spike_ratio / min_noise_sigma). Edge pixels are
// included in the spikes: wrong winners gather there.
void BuildPotholeNoise(DamageFrame& s) {
  const MeasureOptions& mo = s.o.measure;
  const int cell_px = s.o.segment.noise_cell_px;
  if (!s.road_noise.empty() && mo.pothole_min_noise_sigma > 0 && mo.pothole_noise_two_sided)
    s.road_noise = TwoSidedReliefNoise(s.road_noise, s.relief.value, s.reliable, s.scale.road_level, cell_px,
                                       s.scale.sigma, kStructureSigmaRatio, kMatchingNoiseMaxAsymmetry, s.f.labels);
  s.measure_noise = mo.pothole_min_noise_sigma > 0 ? s.road_noise : cv::Mat();
  if (s.measure_noise.empty() || !(mo.pothole_min_spike_ratio > 0)) return;
  const cv::Mat spikes = LocalReliefSpikes(s.relief.value, s.relief.valid, s.scale.road_level, cell_px, s.scale.sigma,
                                           kStructureSigmaRatio, mo.spike_quantile);
  // max(road_noise, spikes · k) in one pass (as cv::max of the scaled copy: OpenCV scales a
  // float image by the float factor, one rounding).
  const float k = static_cast<float>(mo.pothole_min_spike_ratio / mo.pothole_min_noise_sigma);
  s.measure_noise = cv::Mat(s.road_noise.size(), CV_32F);  // a new image: road_noise is kept
  tbb::parallel_for(0, s.road_noise.rows, [&](int v) {
    const float* rn = s.road_noise.ptr<float>(v);
    const float* sp = spikes.ptr<float>(v);
    float* m = s.measure_noise.ptr<float>(v);
    for (int u = 0; u < s.road_noise.cols; ++u) m[u] = std::max(rn[u], sp[u] * k);
  });
}

void Measure(DamageFrame& s) {
  // The volume is summed on the disparity stage's sharp image where given (sharp_disparity.h).
  const cv::Mat sharp_depth_mm = s.sharp_disparity_px.empty()
                                     ? cv::Mat()
                                     : SharpDepthBelowMm(s.sharp_disparity_px, s.disparity_px, s.f.labels, s.g,
                                                         s.f.surface, s.f.relief.correction_mm);
  s.f.instances =
      MeasureDepressions(s.f.labels, s.f.relief, s.g, s.f.surface, s.o.measure, s.measure_noise, sharp_depth_mm);
}

// Oblique views: may the near rim hide the floor (depth and volume then lower bounds)?
void FloorVisibility(DamageFrame& s) {
  AnalyseFloorVisibility(s.f.instances, s.f.labels, s.f.relief, s.g, s.f.surface, s.o.measure);
}

bool WantsCracks(const DamageFrame& s) { return s.want_cracks; }
void Cracks(DamageFrame& s) {
  s.image_work.wait();
  // relief.valid: the road mask (valid, not obstacle), here without its islands; RefineRoadRelief changes neither mask.
  const cv::Mat crack_road = s.has_islands ? cv::Mat(s.relief.valid & (s.islands == 0)) : s.relief.valid;
  const CrackDetection cracks =
      DetectCracks(s.left_image, crack_road, s.f.labels != 0, s.pixel_size, s.o.crack, s.crack_response);
  AddCracks(cracks, s.f.labels, s.f.instances);
}

// Cracks get their range and σ_Z; every instance its grades.
void Grade(DamageFrame& s) {
  const std::vector<cv::Rect> boxes = LabelBoxes(s.f.labels);
  for (DamageInstance& d : s.f.instances) {
    if (d.type == DamageType::kCrack && d.id < static_cast<int>(boxes.size()) && !boxes[d.id].empty()) {
      const cv::Rect& b = boxes[d.id];
      d.range_m = cv::mean(s.f.relief.road_depth_m(b), s.f.labels(b) == d.id)[0];
      d.sigma_depth_m = StereoDepthSigma(d.range_m, s.o.measure.sigma_disparity_px, s.g);
      // The outline on the fitted road (a crack is no depth the disparity resolves): what places it on the map.
      d.outline_cam_m.clear();
      for (const cv::Point& p : d.outline_px)
        if (const double z = s.f.surface.RayDepth(s.g, p.x, p.y); std::isfinite(z)) {
          const Eigen::Vector3d q = CameraPointAtDepth(s.g, p.x, p.y, z);
          d.outline_cam_m.emplace_back(q.x(), q.y(), q.z());
        }
    }
    GradeInstance(d, s.o.severity);
  }
}

// One pass of DetectDamage; `applies` (null: always) skips it for the frame.
struct DamagePass {
  const char* name;
  void (*run)(DamageFrame&);
  bool (*applies)(const DamageFrame&) = nullptr;
};

// The algorithm, in order.
const DamagePass kPasses[] = {
    {"paint edges", StartPaintEdges},
    {"range limit", LimitRange},
    {"road fit", FitRoad},
    {"relief", ComputeRelief},
    {"road mask", PrepareRoadMask},
    {"noise map", BuildNoiseMaps},
    {"segmentation", Segment},
    {"obstacle removal", RemoveObstacles},
    {"road refinement", RefineRoad, WantsRefinement},
    {"rim", ExtendRims},
    {"pothole noise", BuildPotholeNoise},
    {"measurement", Measure},
    {"floor visibility", FloorVisibility},
    {"cracks", Cracks, WantsCracks},
    {"grading", Grade},
};

}  // namespace

double FrameDamage::PassMs(std::string_view name) const {
  for (const PassTime& p : pass_ms)
    if (p.name == name) return p.ms;
  return 0;
}

std::vector<std::string> DamagePassNames() {
  std::vector<std::string> names;
  for (const DamagePass& p : kPasses) names.emplace_back(p.name);
  return names;
}

FrameDamage DetectDamage(const cv::Mat& input_disparity_px, const cv::Mat& left_image, const RectifiedStereo& g,
                         const DamageOptions& o, const cv::Mat& sharp_disparity_px) {
  if (!left_image.empty() && left_image.size() != input_disparity_px.size())
    throw std::invalid_argument("DetectDamage: left image and disparity differ in size");
  if (!g.Valid()) throw std::invalid_argument("DetectDamage: stereo geometry needs f > 0 and baseline > 0");
  if (input_disparity_px.type() != CV_32FC1) throw std::invalid_argument("DetectDamage: disparity must be CV_32FC1");
  DamageFrame s(input_disparity_px, left_image, g, o, sharp_disparity_px);
  for (const DamagePass& p : kPasses) {
    if (p.applies && !p.applies(s)) continue;
    const auto t0 = std::chrono::steady_clock::now();
    p.run(s);
    s.f.pass_ms.push_back({p.name, MsSince(t0)});
  }
  return std::move(s.f);
}

TransformedSegmentation SegmentTransformedDisparity(const cv::Mat& transformed, const cv::Mat& left_image,
                                                    const DamageOptions& o, std::optional<ReliefScale> scale) {
  o.Check();
  if (!left_image.empty() && left_image.size() != transformed.size())
    throw std::invalid_argument("SegmentTransformedDisparity: left image and disparity differ in size");
  const ReliefImage relief = ToRelief(transformed);
  const DepressionSegmentation seg = SegmentOnLocalLevel(relief, o.segment, scale);
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
    const double mean_z =
        (cv::mean(relief.value, (seg.labels == id) & relief.valid)[0] - seg.scale.road_level) / seg.scale.sigma;
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
