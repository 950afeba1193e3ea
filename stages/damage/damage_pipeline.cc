#include "stages/damage/damage_pipeline.h"

#include "stages/damage/cracks.h"
#include "stages/damage/measure.h"
#include "stages/damage/severity.h"

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <random>
#include <stdexcept>

namespace rs {
namespace {

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Appends crack instances to `labels`/`instances` with ids after the depressions.
void AddCracks(const CrackDetection& cracks, cv::Mat& labels, std::vector<DamageInstance>& instances) {
  const int base = instances.empty() ? 0 : instances.back().id;
  for (DamageInstance d : cracks.instances) {
    if (base + d.id > 65535) break;
    const int old_id = d.id;
    d.id = base + old_id;
    labels.setTo(d.id, (cracks.labels == old_id) & (labels == 0));
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

FrameDamage DetectDamage(const cv::Mat& disparity_px, const cv::Mat& left_image, const StereoGeometry& g,
                         const DamageOptions& o) {
  o.Check();
  if (!left_image.empty() && left_image.size() != disparity_px.size())
    throw std::invalid_argument("DetectDamage: left image and disparity differ in size");
  FrameDamage f;
  auto t0 = std::chrono::steady_clock::now();
  f.surface = FitRoadSurface(disparity_px, g, o.road);
  f.relief = ComputeRoadRelief(disparity_px, g, f.surface, o.road);
  f.ms_road = MsSince(t0);

  t0 = std::chrono::steady_clock::now();
  ReliefImage relief{f.relief.transformed_disparity_px, f.relief.valid_mask & (f.relief.obstacle_mask == 0)};
  const cv::Mat area = PixelAreaOnRoad(f.relief, g, f.surface);
  const DepressionSegmentation seg = SegmentDepressions(relief, o.segment, area);
  f.labels = seg.labels;
  f.threshold_sigma = seg.threshold_sigma;
  if (o.road.local_cell_px > 0 && seg.count > 0) {
    // The local road correction, recomputed without the found depressions (grown by half a
    // cell), no longer leans into large shallow damage: depths and rims are measured on it.
    cv::Mat exclude;
    const int r = std::max(1, o.road.local_cell_px / 2);
    cv::dilate(f.labels != 0, exclude, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
    f.relief = ComputeRoadRelief(disparity_px, g, f.surface, o.road, exclude);
  }
  ExtendToRim(f.labels, f.relief, o.segment.rim_depth_m);
  f.ms_segment = MsSince(t0);

  t0 = std::chrono::steady_clock::now();
  f.instances = MeasureDepressions(f.labels, f.relief, g, f.surface, o.measure);
  f.ms_measure = MsSince(t0);

  if (o.crack.enabled && !left_image.empty()) {
    t0 = std::chrono::steady_clock::now();
    cv::Mat pixel_size;
    cv::sqrt(area, pixel_size);  // metres per pixel on the road (NaN off-road)
    const cv::Mat road = f.relief.valid_mask & (f.relief.obstacle_mask == 0);
    const CrackDetection cracks = DetectCracks(left_image, road, f.labels != 0, pixel_size, o.crack);
    AddCracks(cracks, f.labels, f.instances);
    f.ms_cracks = MsSince(t0);
  }
  for (DamageInstance& d : f.instances) {
    if (d.type == DamageType::kCrack) {
      d.range_m = cv::mean(f.relief.road_depth_m, f.labels == d.id)[0];
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

cv::Mat SyntheticRoadScene::Render() const {
  const double th = pitch_deg * CV_PI / 180.0;
  const Eigen::Vector3d up(0, -std::cos(th), -std::sin(th));  // road normal towards the camera, camera frame
  // Pothole centre: on the plane, straight ahead in the image's centre column at depth pothole_z_m.
  // Ray through (cx, v): z = 1, y = (v − cy)/f; solve up·(Z r) = −H for the row that gives Z.
  const double yz = (-height_m / pothole_z_m - up.z()) / up.y();  // y/z of the ray hitting the plane at Z
  const Eigen::Vector3d c0 = pothole_z_m * Eigen::Vector3d(0, yz, 1);
  const double a = pothole_radius_m, h = pothole_depth_m, R = (a * a + h * h) / (2 * h);
  const Eigen::Vector3d sphere = c0 + up * (R - h);
  const Eigen::Vector3d e1 = Eigen::Vector3d::UnitX(), e2 = up.cross(e1);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_d_px);
  cv::Mat d(height, width, CV_32F);
  const double fb = geometry.f_px * geometry.baseline_m;
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d r((u - geometry.cx_px) / geometry.f_px, (v - geometry.cy_px) / geometry.f_px, 1.0);
      const double ur = up.dot(r);
      if (ur >= -1e-9) { d.at<float>(v, u) = 0; continue; }  // above the horizon: no road
      double z = -height_m / ur;
      const Eigen::Vector3d p = z * r;
      if (box_height_m > 0) {  // slab top at box_height_m, to the right of the pothole, 0.6 m × 0.6 m
        const double zt = -(height_m - box_height_m) / ur;
        const Eigen::Vector3d q = zt * r - c0;
        const double s = e1.dot(q), t = e2.dot(q);
        if (s > 0.45 && s < 1.05 && t > -0.3 && t < 0.3) z = zt;
      }
      if (z == -height_m / ur && (p - c0).norm() < a) {
        // Far intersection of the ray with the sphere = the bowl's surface below the plane.
        const double b = r.dot(sphere), cc = sphere.squaredNorm() - R * R, rr = r.squaredNorm();
        const double disc = b * b - rr * cc;
        if (disc > 0) z = (b + std::sqrt(disc)) / rr;
      }
      d.at<float>(v, u) = static_cast<float>(fb / z + noise(rng));
    }
  return d;
}

double SyntheticRoadScene::TrueAreaM2() const { return CV_PI * pothole_radius_m * pothole_radius_m; }

double SyntheticRoadScene::TrueVolumeM3() const {
  const double a = pothole_radius_m, h = pothole_depth_m, R = (a * a + h * h) / (2 * h);
  return CV_PI * h * h * (3 * R - h) / 3.0;
}

DamageBench BenchDetectDamage(int width, int height, int repeats) {
  SyntheticRoadScene scene;
  scene.width = width, scene.height = height;
  scene.geometry = {width * 0.78, width / 2.0, height / 2.0, 0.20};
  const cv::Mat disparity = scene.Render();
  std::vector<double> wall, cpu;
  for (int i = 0; i < std::max(1, repeats); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    const FrameDamage f = DetectDamage(disparity, cv::Mat(), scene.geometry, DamageOptions());
    cpu.push_back(1000.0 * double(std::clock() - c0) / CLOCKS_PER_SEC);
    wall.push_back(MsSince(t0));
  }
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  return {wall[wall.size() / 2], cpu[cpu.size() / 2]};
}

}  // namespace rs
