#include "stages/damage/measure/measure.h"
#include "sim/synthetic_damage_scene.h"

#include "stages/damage/damage_pipeline.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rs {
namespace {

// Measurement exactness on a spherical-cap pothole in a noisy plane (σ_d = 0.05 px).
// Tolerances (done criteria): max depth ±10 mm, area ±10 %, volume ±15 %.
void CheckCap(double depth_m, double radius_m, double z_m) {
  SyntheticRoadScene scene;
  scene.pothole_depth_m = depth_m;
  scene.pothole_radius_m = radius_m;
  scene.pothole_z_m = z_m;
  const FrameDamage f = DetectDamage(scene.Render(), cv::Mat(), scene.geometry, DamageOptions());
  ASSERT_EQ(f.instances.size(), 1u);
  const DamageInstance& d = f.instances[0];
  std::printf("cap h=%.0f mm a=%.0f mm Z=%.1f m: depth %.1f mm, area %.4f/%.4f m2, volume %.6f/%.6f m3\n",
              depth_m * 1000, radius_m * 1000, z_m, d.max_depth_m * 1000, d.area_m2, scene.TrueAreaM2(), d.volume_m3,
              scene.TrueVolumeM3());
  EXPECT_EQ(d.type, DamageType::kPothole);
  EXPECT_NEAR(d.max_depth_m, depth_m, 0.010);
  EXPECT_NEAR(d.area_m2, scene.TrueAreaM2(), 0.10 * scene.TrueAreaM2());
  EXPECT_NEAR(d.volume_m3, scene.TrueVolumeM3(), 0.15 * scene.TrueVolumeM3());
  EXPECT_NEAR(d.equivalent_diameter_m, 2 * radius_m, 0.05 * 2 * radius_m);
  EXPECT_NEAR(d.max_diameter_m, 2 * radius_m, 0.08 * 2 * radius_m);
  EXPECT_LT(d.mean_depth_m, d.max_depth_m);
  // The stated uncertainties hold the errors (2 σ), and are of the outline's size: σ_area about
  // the outline's length times its position uncertainty (1.5-4.5 px at these depths).
  EXPECT_LE(std::abs(d.area_m2 - scene.TrueAreaM2()), 2 * d.sigma_area_m2);
  EXPECT_LE(std::abs(d.volume_m3 - scene.TrueVolumeM3()), 2 * d.sigma_volume_m3);
  EXPECT_GT(d.sigma_area_m2, 0.01 * d.area_m2);
  EXPECT_LT(d.sigma_area_m2, 0.25 * d.area_m2);
  // σ_Z = Z²σ_d/(fB) at the pothole's range.
  EXPECT_NEAR(d.sigma_depth_m, d.range_m * d.range_m * 0.25 / (1000 * 0.2), 1e-9);
  EXPECT_NEAR(d.range_m, z_m, 0.1 * z_m);
  // The camera-frame outline lies on the road plane, around the centre.
  ASSERT_GT(d.outline_cam_m.size(), 8u);
}

TEST(MeasureDepressions, Nominal) { CheckCap(0.06, 0.25, 2.2); }
TEST(MeasureDepressions, ShallowWide) { CheckCap(0.035, 0.40, 2.5); }
TEST(MeasureDepressions, DeepSmall) { CheckCap(0.08, 0.15, 1.9); }

// ExtendToRim on a hand-made relief: a depression whose wall runs linearly from `depth_mm` at
// normalised radius 0.75 to 0 at the rim (radius 1), on an ellipse of semi-axes a (columns) and
// b (rows); the truth opening is the ellipse, π·a·b px. `tilt_mm_per_px`: the road around rises
// (negative depth) to the right, a local misfit of the road model.
struct RimScene {
  int width = 320, height = 200;
  double cu = 160, cv = 100, a = 40, b = 40, depth_mm = 40, tilt_mm_per_px = 0;
  bool tangential = false;  ///< smoothstep wall (leaves the road tangentially) instead of linear
  double noise_mm = 0;      ///< Gaussian noise on the depth (seeded)
  double Q(int u, int v) const { return std::hypot((u - cu) / a, (v - cv) / b); }
  RoadRelief Relief() const {
    RoadRelief r;
    r.depth_below_mm.create(height, width, CV_32F);
    r.obstacle_mask = cv::Mat::zeros(height, width, CV_8U);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        const double q = Q(u, v), t = std::clamp((1 - q) / 0.25, 0.0, 1.0);
        const double wall = tangential ? t * t * (3 - 2 * t) : t;
        r.depth_below_mm.at<float>(v, u) = static_cast<float>(depth_mm * wall + tilt_mm_per_px * (cu - u));
      }
    if (noise_mm > 0) {
      cv::Mat n(height, width, CV_32F);
      cv::RNG rng(7);
      rng.fill(n, cv::RNG::NORMAL, 0.0, noise_mm);
      r.depth_below_mm += n;
    }
    return r;
  }
  // Labels: the ellipse scaled by `scale`, columns left of `cut_u` removed.
  cv::Mat Labels(double scale, int cut_u = 0) const {
    cv::Mat l = cv::Mat::zeros(height, width, CV_16U);
    for (int v = 0; v < height; ++v)
      for (int u = cut_u; u < width; ++u)
        if (Q(u, v) < scale) l.at<uint16_t>(v, u) = 1;
    return l;
  }
  double TruthPx() const { return CV_PI * a * b; }
};

// Superpixels straddling the rim join the segmentation on a 40 % vote and take road with them:
// the outline follows the depth instead (before: the 6-px overshoot stayed, area +31.7 %).
TEST(ExtendToRim, DropsRoadBeyondTheRim) {
  const RimScene s;
  cv::Mat labels = s.Labels(46.0 / 40.0);
  ExtendToRim(labels, s.Relief(), 0.001, 0.03, 7);
  EXPECT_NEAR(cv::countNonZero(labels), s.TruthPx(), 0.03 * s.TruthPx());
}

// The road around rises 0.2 mm/px to the right (±10 mm over the ring, a verge beside the lane):
// the rim threshold stands on a plane through the ring, not on its median, whose spread the tilt
// inflated (before: area -9.9 %).
TEST(ExtendToRim, LevelIsThePlaneOfTheSurroundingRoad) {
  RimScene s;
  s.tilt_mm_per_px = 0.2;
  cv::Mat labels = s.Labels(0.8);
  ExtendToRim(labels, s.Relief(), 0.001, 0.03, 7);
  EXPECT_NEAR(cv::countNonZero(labels), s.TruthPx(), 0.03 * s.TruthPx());
}

// A foreshortened pothole (rows 4× longer on the road than columns: round on the road, 4× wider
// than tall in the image) whose left end the segmentation cut off: the band is 30 % of the radius
// on the road, so it reaches the end (before: a band of whole pixels, 11 px across, left -4.2 %).
TEST(ExtendToRim, BandMeasuredOnTheRoad) {
  RimScene s;
  s.a = 80, s.b = 20;
  cv::Mat labels = s.Labels(1.0, static_cast<int>(s.cu - 0.7 * s.a));
  ExtendToRim(labels, s.Relief(), 0.001, 0.03, 7, std::vector<double>(s.height, 4.0));
  EXPECT_NEAR(cv::countNonZero(labels), s.TruthPx(), 0.03 * s.TruthPx());
}

// A wall leaving the road tangentially (smoothstep over the outer quarter of the radius, as the
// simulator's potholes; depth noise 0.05 mm): at the 3 % threshold (1.2 mm) the outline stops
// 1.5 px inside the opening of 60 px radius. The wall's outer rings are extended to the road as
// a power law fitted to them (p = 2 here); before, at their slope (first order), which closed
// half the gap: -2.2 %.
TEST(ExtendToRim, TangentialWallExtendedToTheRoad) {
  RimScene s;
  s.a = s.b = 60, s.tangential = true, s.noise_mm = 0.05;
  cv::Mat labels = s.Labels(0.8);
  ExtendToRim(labels, s.Relief(), 0.001, 0.03, 7);
  EXPECT_NEAR(cv::countNonZero(labels), s.TruthPx(), 0.02 * s.TruthPx());
}

// Guard: the same extension leaves a wall meeting the road at an angle (linear: p = 1) where the
// threshold put it (within 2 %): a fit free to choose p = 2 must not read it as tangential.
TEST(ExtendToRim, SharpEdgeNotOvergrown) {
  RimScene s;
  s.a = s.b = 60, s.noise_mm = 0.05;
  cv::Mat labels = s.Labels(0.8);
  ExtendToRim(labels, s.Relief(), 0.001, 0.03, 7);
  EXPECT_NEAR(cv::countNonZero(labels), s.TruthPx(), 0.02 * s.TruthPx());
}

// An oblique view (rows e = 3.5 times longer on the road than columns, a car camera's rays at
// 16.6° to the road, 5 mm columns): a round pothole of radius 40 columns (80 x 23 px) with the
// simulator's wall (smoothstep over the outer 30 % of the radius, bowl 1 - q²/4), ray-cast: a
// pixel's depth is that of the point where its ray, after crossing the road, meets the surface.
// The near rim occludes (the depth jumps there), the far wall is seen along grazing rays, the
// side walls about as from above. The truth opening: pixels whose ray crosses the road inside it.
struct ObliqueRimScene {
  int width = 320, height = 100;
  double cu = 160, cv = 50, radius = 40, depth_mm = 80, e = 3.5, mm_per_col = 5;
  bool tangential = true;  ///< smoothstep wall, else linear over the outer 30 %
  double Q(double x, double y) const { return std::hypot(x, y) / radius; }  // road units
  double Surface(double x, double y) const {
    const double q = Q(x, y);
    if (q >= 1) return 0;
    const double t = std::clamp((1 - q) / 0.3, 0.0, 1.0);
    return depth_mm * (tangential ? t * t * (3 - 2 * t) : t) * (1 - 0.25 * q * q);
  }
  // Road coordinates of pixel (u, v): x across, y along the view (nearer = larger v = larger y).
  double X(int u) const { return u - cu; }
  double Y(int v) const { return (v - cv) * e; }
  RoadRelief Relief() const {
    RoadRelief r;
    r.depth_below_mm.create(height, width, CV_32F);
    r.obstacle_mask = cv::Mat::zeros(height, width, CV_8U);
    const double slope = mm_per_col / std::sqrt(e * e - 1);  // ray's descent (mm) per road unit run
    cv::RNG rng(7);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        double seen = 0;
        if (Q(X(u), Y(v)) < 1)
          for (double s = 0; s < 2 * radius; s += 0.01)  // run towards the far side (smaller y)
            if (const double h = Surface(X(u), Y(v) - s); slope * s >= h) {
              seen = h;
              break;
            }
        r.depth_below_mm.at<float>(v, u) = static_cast<float>(seen + rng.gaussian(0.05));
      }
    return r;
  }
  cv::Mat Labels(double scale) const {  // the opening scaled by `scale`
    cv::Mat l = cv::Mat::zeros(height, width, CV_16U);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u)
        if (Q(X(u), Y(v)) < scale) l.at<uint16_t>(v, u) = 1;
    return l;
  }
  double TruthPx() const { return cv::countNonZero(Labels(1.0)); }
};

// Each side extended where a wall is seen, as the view shows it: the far side along columns (the
// seen depth there is the ray's, so its outline stopped ~1 row short), the lateral sides along
// rows, the near rim (an occluding edge) left: -0.3 %. Before: not extended in oblique views,
// -7.0 % (the simulator's car preset, truth disparity: bias -7.8 %); rings all round dilated by
// whole pixels: +60 % on the car preset.
TEST(ExtendToRim, ObliqueViewExtendsTheSeenWalls) {
  const ObliqueRimScene s;
  cv::Mat labels = s.Labels(0.8);
  ExtendToRim(labels, s.Relief(), 0.001, 0.03, 7, std::vector<double>(s.height, s.e));
  EXPECT_NEAR(cv::countNonZero(labels), s.TruthPx(), 0.03 * s.TruthPx());
}

// A wall meeting the road at an angle (linear over the outer 30 %) in the same view: extended to
// its opening (+2.0 %; before -3.8 %), not beyond it.
TEST(ExtendToRim, ObliqueViewSharpEdgeNotOvergrown) {
  ObliqueRimScene s;
  s.tangential = false;
  cv::Mat labels = s.Labels(0.8);
  ExtendToRim(labels, s.Relief(), 0.001, 0.03, 7, std::vector<double>(s.height, s.e));
  EXPECT_NEAR(cv::countNonZero(labels), s.TruthPx(), 0.03 * s.TruthPx());
}

TEST(MeasureDepressions, WrongLabelType) {
  SyntheticRoadScene scene;
  RoadRelief r;
  r.depth_below_mm = cv::Mat::zeros(10, 10, CV_32F);
  EXPECT_THROW(MeasureDepressions(cv::Mat::zeros(10, 10, CV_8U), r, scene.geometry, RoadSurface(), MeasureOptions()),
               std::invalid_argument);
}

// LabelBoxes (16 zero labels skipped at once, runs of one id) against a per-pixel reference at an
// awkward size: rectangles, single pixels and runs crossing 16-pixel blocks, up to the frame edges.
TEST(LabelBoxes, EqualsPerPixelReference) {
  cv::Mat labels = cv::Mat::zeros(357, 631, CV_16U);
  cv::RNG rng(7);
  for (int i = 0; i < 60; ++i) {
    const int id = rng.uniform(1, 40), u = rng.uniform(0, labels.cols), v = rng.uniform(0, labels.rows);
    const cv::Rect r = cv::Rect(u, v, rng.uniform(1, 70), rng.uniform(1, 20)) & cv::Rect({}, labels.size());
    labels(r).setTo(id);
  }
  labels.at<uint16_t>(0, 0) = 41, labels.at<uint16_t>(356, 630) = 42, labels.at<uint16_t>(200, 15) = 43;
  labels.row(100).colRange(14, 34).setTo(44);
  std::vector<cv::Rect> expected(45);
  for (int v = 0; v < labels.rows; ++v)
    for (int u = 0; u < labels.cols; ++u)
      if (const int id = labels.at<uint16_t>(v, u); id > 0)
        expected[id] = expected[id].empty() ? cv::Rect(u, v, 1, 1) : expected[id] | cv::Rect(u, v, 1, 1);
  std::vector<cv::Rect> boxes = LabelBoxes(labels);
  boxes.resize(std::max(boxes.size(), expected.size()));
  for (size_t id = 1; id < expected.size(); ++id) EXPECT_EQ(boxes[id], expected[id]) << "id " << id;
}

}  // namespace
}  // namespace rs
