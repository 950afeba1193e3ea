#include "stages/damage/measure/floor_visibility.h"
#include "sim/synthetic_damage_scene.h"

#include "stages/damage/output/damage_output.h"
#include "stages/damage/damage_pipeline.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace rs {
namespace {

// A spherical-cap pothole ray-traced exactly (SyntheticRoadScene: the near wall hides what
// lies behind it), seen from a camera `height_m` above the road, pitched `pitch_deg`.
struct Case {
  double height_m, pitch_deg, depth_m, radius_m, z_m;
};

struct Truth {
  double visible_depth_m = 0;  ///< deepest point any pixel sees (noise-free render)
  double tan_rim = 0;          ///< elevation of the ray to the near rim
};

SyntheticRoadScene Scene(const Case& c) {
  SyntheticRoadScene s;
  s.geometry.baseline_m = 0.3;  // the simulator's rig: analysed range 7.7 m
  s.height_m = c.height_m, s.pitch_deg = c.pitch_deg;
  s.pothole_depth_m = c.depth_m, s.pothole_radius_m = c.radius_m, s.pothole_z_m = c.z_m;
  s.sigma_d_px = 0.02;
  return s;
}

// What the frame can see, from the noise-free render: the largest depth below the road plane
// of any seen point, and the near rim's ray elevation (scene frame as in synthetic_scene.cc).
Truth TruthOf(const Case& c) {
  SyntheticRoadScene s = Scene(c);
  s.sigma_d_px = 0;
  const cv::Mat disp = s.Render();
  const double th = c.pitch_deg * CV_PI / 180;
  const Eigen::Vector3d up(0, -std::cos(th), -std::sin(th));
  Truth t;
  for (int v = 0; v < disp.rows; ++v)
    for (int u = 0; u < disp.cols; ++u) {
      const float d = disp.at<float>(v, u);
      if (!(d > 0)) continue;
      const double z = s.geometry.f_px * s.geometry.baseline_m / d;
      const Eigen::Vector3d p((u - s.geometry.cx_px) * z / s.geometry.f_px,
                              (v - s.geometry.cy_px) * z / s.geometry.f_px, z);
      t.visible_depth_m = std::max(t.visible_depth_m, -(up.dot(p) + c.height_m));
    }
  const double yz = (-c.height_m / c.z_m - up.z()) / up.y();
  const Eigen::Vector3d centre = c.z_m * Eigen::Vector3d(0, yz, 1), along = up.cross(Eigen::Vector3d::UnitX());
  const Eigen::Vector3d rim = centre - c.radius_m * along, foot = -c.height_m * up;
  t.tan_rim = c.height_m / along.dot(rim - foot);
  return t;
}

// Runs the whole frame (DetectDamage calls the analysis) and checks the flag and the bounds
// against the exact geometry. Returns the single detection.
DamageInstance Check(const Case& c, bool expect_visible) {
  const SyntheticRoadScene scene = Scene(c);
  const Truth truth = TruthOf(c);
  const FrameDamage f = DetectDamage(scene.Render(), cv::Mat(), scene.geometry, DamageOptions());
  EXPECT_EQ(f.instances.size(), 1u);
  if (f.instances.empty()) return {};
  const DamageInstance& d = f.instances[0];
  const double hidden_m = c.depth_m - truth.visible_depth_m;
  std::printf(
      "cap %.0f mm / %.0f mm at %.1f m, pitch %.0f: visible %.1f mm (hidden %.1f), measured %.1f mm, "
      "sigma_Z %.1f mm, e %.1f deg (truth %.1f), floor %s, bound %.1f mm, volume %.6f (upper %.6f, true %.6f)\n",
      c.depth_m * 1000, c.radius_m * 1000, c.z_m, c.pitch_deg, truth.visible_depth_m * 1000, hidden_m * 1000,
      d.max_depth_m * 1000, d.sigma_depth_m * 1000, d.grazing_angle_deg, std::atan(truth.tan_rim) * 180 / CV_PI,
      d.floor_visible ? "seen" : "hidden", d.max_depth_bound_m * 1000, d.volume_m3, d.volume_upper_m3,
      scene.TrueVolumeM3());
  // The geometry's own verdict: this cap's floor hidden by more than 10 mm, or seen.
  EXPECT_EQ(hidden_m <= 0.010, expect_visible) << "test case does not show what it is meant to";
  EXPECT_EQ(d.floor_visible, expect_visible);
  // The grazing angle over the near rim (the rim detected within a pixel or two; at steep
  // views the angle varies across the pothole by more than that).
  if (c.pitch_deg < 30) {
    EXPECT_NEAR(d.grazing_angle_deg, std::atan(truth.tan_rim) * 180 / CV_PI, 1.5);
  }
  // Lower bound: seen − 2 σ_Z never exceeds the truth.
  EXPECT_LE(d.max_depth_seen_m - 2 * d.sigma_depth_m, c.depth_m);
  if (expect_visible) {
    EXPECT_NEAR(d.max_depth_m, c.depth_m, 0.010);  // the Done-when bound where the floor is seen
    EXPECT_EQ(d.max_depth_m, d.max_depth_seen_m);  // nothing to complete
    EXPECT_TRUE(std::isnan(d.max_depth_bound_m));
  } else {
    EXPECT_LT(d.max_depth_seen_m, c.depth_m - 0.010);  // what the frame shows falls short
    EXPECT_GE(d.max_depth_bound_m, c.depth_m);         // the bound holds the truth
    EXPECT_LE(d.max_depth_bound_m, 4 * c.depth_m);     // and says something
    EXPECT_GE(d.volume_upper_m3, scene.TrueVolumeM3());
    EXPECT_LT(d.volume_seen_m3, scene.TrueVolumeM3());
    EXPECT_GT(d.hidden_length_m, 0.0);
    EXPECT_LT(d.hidden_length_m, 2 * c.radius_m);
    // The estimate lies within the stated interval.
    EXPECT_GE(d.max_depth_m, d.max_depth_seen_m);
    EXPECT_LE(d.max_depth_m, d.max_depth_bound_m);
  }
  EXPECT_GE(d.volume_m3, d.volume_seen_m3);
  if (std::isfinite(d.volume_upper_m3)) {
    EXPECT_LE(d.volume_m3, d.volume_upper_m3);
  }
  // The detections JSON carries the verdict; unknown bounds are null, never 0.
  const nlohmann::json j = DetectionsToJson({d})["detections"][0];
  EXPECT_EQ(j["floor_visible"].get<bool>(), expect_visible);
  EXPECT_EQ(j["max_depth_bound_m"].is_null(), expect_visible);
  EXPECT_EQ(j["volume_upper_m3"].is_null(), !std::isfinite(d.volume_upper_m3));
  EXPECT_DOUBLE_EQ(j["max_depth_seen_m"].get<double>(), d.max_depth_seen_m);
  EXPECT_DOUBLE_EQ(j["volume_seen_m3"].get<double>(), d.volume_seen_m3);
  return d;
}

// The estimate against the exact cap: volume within `volume_tol` (relative), max depth within
// `depth_tol_m`, where what the frame sees (the old volume_m3 / max_depth_m) misses the same
// tolerance (the test of the completion, not of the measurement). Measured: 80 mm
// cap 81.9 mm, −4.5 % (seen 59 mm, −43 %); 120 mm cap 122.3 mm, −5.9 % (seen 77 mm, −54 %;
// −14.2 % while the near wall was held to the 45° bound's slope, hence its 10 % here); wedge
// case −3.3 % (seen −8.8 %, area +0.7 %).
void ExpectEstimate(const Case& c, const DamageInstance& d, double volume_tol, double depth_tol_m) {
  const double v = Scene(c).TrueVolumeM3();
  std::printf(
      "  estimate: depth %.1f mm (seen %.1f, true %.1f), volume %.6f (seen %.6f, true %.6f): %+.1f %% (seen %+.1f %%), "
      "area %+.1f %%\n",
      d.max_depth_m * 1000, d.max_depth_seen_m * 1000, c.depth_m * 1000, d.volume_m3, d.volume_seen_m3, v,
      100 * (d.volume_m3 / v - 1), 100 * (d.volume_seen_m3 / v - 1), 100 * (d.area_m2 / Scene(c).TrueAreaM2() - 1));
  EXPECT_NEAR(d.volume_m3, v, volume_tol * v);
  EXPECT_GT(std::abs(d.volume_seen_m3 - v), volume_tol * v) << "the seen volume alone would pass";
  EXPECT_NEAR(d.max_depth_m, c.depth_m, depth_tol_m);
}

// A car's view (1.5 m, pitched 15°): a deep cap at 6 m (grazing ~14°) hides its floor.
TEST(FloorVisibility, CarDeepCapHidden) {
  const Case c{1.5, 15, 0.08, 0.15, 6.0};
  ExpectEstimate(c, Check(c, false), 0.15, 0.010);
}
TEST(FloorVisibility, CarDeeperCapNearerHidden) {
  const Case c{1.5, 15, 0.12, 0.15, 5.0};
  ExpectEstimate(c, Check(c, false), 0.10, 0.010);
}
// A wide cap whose floor the car sees, but not the near wall's wedge behind the rim.
TEST(FloorVisibility, CarWideCapWedge) {
  const Case c{1.5, 15, 0.12, 0.35, 4.0};
  ExpectEstimate(c, Check(c, true), 0.06, 0.010);
}
// The same view, a shallow wide cap: the rays reach its floor.
TEST(FloorVisibility, CarShallowCapSeen) { Check({1.5, 15, 0.025, 0.3, 5.0}, true); }
// The deep cap seen steeply (45° pitch at 2.2 m, and a drone 4 m up pitched 80°): nothing hidden.
TEST(FloorVisibility, SteepViewSeen) { Check({1.5, 45, 0.08, 0.15, 2.2}, true); }
TEST(FloorVisibility, NadirSeen) { Check({4.0, 80, 0.10, 0.15, 4.0}, true); }

// A flat-floored pothole (a pan): floor `depth_m` deep out to `floor_radius_m`, then a wall
// rising as a raised cosine to the rim at `radius_m` (leaving the floor and meeting the road
// tangentially), ray-traced exactly in SyntheticRoadScene's camera frame (camera 1.5 m high,
// pitched 15°, the rim's centre on the image's centre column at camera depth `z_m`). Its floor
// is fuller than any cap's: the circle completion alone overshoots its depth where the far wall
// already levels out towards the floor.
struct Pan {
  double depth_m, radius_m, floor_radius_m, z_m;
  double DepthAt(double rho) const {
    if (rho >= radius_m) return 0;
    if (rho <= floor_radius_m) return depth_m;
    return depth_m * 0.5 * (1 + std::cos(CV_PI * (rho - floor_radius_m) / (radius_m - floor_radius_m)));
  }
  double VolumeM3() const {  // ∫ 2πρ depth dρ
    constexpr int kSteps = 4000;
    double v = 0;
    for (int i = 0; i < kSteps; ++i) {
      const double rho = (i + 0.5) * radius_m / kSteps;
      v += 2 * CV_PI * rho * DepthAt(rho) * radius_m / kSteps;
    }
    return v;
  }
};

struct PanFrame {
  cv::Mat disparity;
  RectifiedStereo geometry;
  double visible_depth_m = 0;  ///< deepest point any pixel sees
};

PanFrame RenderPan(const Pan& pan) {
  const double height_m = 1.5, th = 15 * CV_PI / 180;
  PanFrame out;
  out.geometry = Scene({height_m, 15, 0.05, 0.2, pan.z_m}).geometry;
  const RectifiedStereo& g = out.geometry;
  const Eigen::Vector3d up(0, -std::cos(th), -std::sin(th)), e1 = Eigen::Vector3d::UnitX(), e2 = up.cross(e1);
  const double yz = (-height_m / pan.z_m - up.z()) / up.y();
  const Eigen::Vector3d c0 = pan.z_m * Eigen::Vector3d(0, yz, 1);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.02);
  out.disparity = cv::Mat(720, 1280, CV_32F);
  for (int v = 0; v < out.disparity.rows; ++v)
    for (int u = 0; u < out.disparity.cols; ++u) {
      const Eigen::Vector3d r((u - g.cx_px) / g.f_px, (v - g.cy_px) / g.f_px, 1.0);
      const double ur = up.dot(r);
      float& d = out.disparity.at<float>(v, u);
      if (ur >= -1e-9) {
        d = 0;
        continue;
      }
      const double z_road = -height_m / ur;
      // Below-plane depth of the ray at camera depth Z minus the surface's depth under it:
      // positive once the ray has met the surface.
      auto inside = [&](double z) {
        const Eigen::Vector3d q = z * r - c0;
        return (z - z_road) * -ur - pan.DepthAt(std::hypot(e1.dot(q), e2.dot(q)));
      };
      double z = z_road;
      if (inside(z_road + 1e-9) < 0) {  // the ray enters the pan: march to the surface, then bisect
        double lo = z_road, hi = z_road;
        while (inside(hi) < 0) lo = hi, hi += 0.0005;
        for (int i = 0; i < 30; ++i) (inside(0.5 * (lo + hi)) < 0 ? lo : hi) = 0.5 * (lo + hi);
        z = hi;
        out.visible_depth_m = std::max(out.visible_depth_m, (z - z_road) * -ur);
      }
      d = static_cast<float>(g.f_px * g.baseline_m / z + noise(rng));
    }
  return out;
}

// The pan's single detection (DetectDamage calls the analysis).
DamageInstance DetectPan(const Pan& pan, double* visible_depth_m) {
  const PanFrame f = RenderPan(pan);
  *visible_depth_m = f.visible_depth_m;
  const FrameDamage damage = DetectDamage(f.disparity, cv::Mat(), f.geometry, DamageOptions());
  EXPECT_EQ(damage.instances.size(), 1u);
  if (damage.instances.empty()) return {};
  const DamageInstance& d = damage.instances[0];
  std::printf(
      "pan %.0f mm / %.0f mm (floor %.0f) at %.1f m: visible %.1f, seen %.1f, estimate %.1f mm (bound %.1f), "
      "floor %s; volume %.6f (seen %.6f, upper %.6f, true %.6f): %+.1f %% (seen %+.1f %%), area %+.1f %%\n",
      pan.depth_m * 1000, pan.radius_m * 1000, pan.floor_radius_m * 1000, pan.z_m, f.visible_depth_m * 1000,
      d.max_depth_seen_m * 1000, d.max_depth_m * 1000, d.max_depth_bound_m * 1000, d.floor_visible ? "seen" : "hidden",
      d.volume_m3, d.volume_seen_m3, d.volume_upper_m3, pan.VolumeM3(), 100 * (d.volume_m3 / pan.VolumeM3() - 1),
      100 * (d.volume_seen_m3 / pan.VolumeM3() - 1), 100 * (d.area_m2 / (CV_PI * pan.radius_m * pan.radius_m) - 1));
  return d;
}

// Pans whose grazing rays meet the far wall where it levels out onto the floor (the floor
// shows over a row or two, so the stage says hidden): the far wall's slope declines towards the
// grazing point, and the floor lies where that decline reaches zero. The circle through rims and
// grazing point alone goes on down (80 mm pan: 98.4 mm, 100 mm pan: 151.8 mm).
void ExpectPanEstimate(const Pan& pan) {
  double visible_m = 0;
  const DamageInstance d = DetectPan(pan, &visible_m);
  EXPECT_GT(visible_m, pan.depth_m - 0.005) << "test case does not show what it is meant to";
  EXPECT_FALSE(d.floor_visible);
  EXPECT_LE(d.max_depth_seen_m - 2 * d.sigma_depth_m, pan.depth_m);  // the interval holds the truth
  EXPECT_GE(d.max_depth_bound_m, pan.depth_m);
  EXPECT_GE(d.volume_upper_m3, pan.VolumeM3());
  EXPECT_GE(d.max_depth_m, d.max_depth_seen_m);  // the estimate lies inside it
  EXPECT_LE(d.max_depth_m, d.max_depth_bound_m);
  EXPECT_LE(d.volume_m3, d.volume_upper_m3);
  EXPECT_NEAR(d.max_depth_m, pan.depth_m, 0.010);
  EXPECT_NEAR(d.volume_m3, pan.VolumeM3(), 0.15 * pan.VolumeM3());
  EXPECT_GT(std::abs(d.volume_seen_m3 - pan.VolumeM3()), 0.15 * pan.VolumeM3()) << "the seen volume alone would pass";
}
TEST(FloorVisibility, CarPanFloorLevelsOut) { ExpectPanEstimate({0.08, 0.20, 0.12, 5.0}); }
TEST(FloorVisibility, CarDeepPanFloorLevelsOut) { ExpectPanEstimate({0.10, 0.20, 0.14, 5.0}); }

// The frame's disparity smoothed along the image columns over `rows` rows, as a matching
// window and its aggregation smooth it (our SGM disparity spread the near rim's step of car
// renders over 5-7 rows at 6 m). Returns the single pothole.
DamageInstance DetectSmoothed(const Case& c, int rows) {
  const SyntheticRoadScene scene = Scene(c);
  // Averaged over the valid pixels only (the sky has none): no false step at the horizon.
  const cv::Mat raw = scene.Render();
  cv::Mat valid, sum, count, disp;
  raw.convertTo(valid, CV_32F);
  valid = valid > 0;
  valid.convertTo(valid, CV_32F, 1.0 / 255);
  cv::blur(raw, sum, cv::Size(1, rows), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  cv::blur(valid, count, cv::Size(1, rows), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  cv::divide(sum, cv::max(count, 1e-6), disp);
  disp.setTo(0, raw <= 0);
  const FrameDamage f = DetectDamage(disp, cv::Mat(), scene.geometry, DamageOptions());
  // The pothole (the smoothing leaves 2 mm "other" ripples at the bottom rows).
  std::vector<DamageInstance> potholes;
  for (const DamageInstance& d : f.instances)
    if (d.type == DamageType::kPothole) potholes.push_back(d);
  EXPECT_EQ(potholes.size(), 1u);
  if (potholes.empty()) return {};
  const DamageInstance& d = potholes[0];
  std::printf(
      "cap %.0f mm / %.0f mm at %.1f m, smoothed over %d rows: seen %.1f mm, floor %s, bound %.1f mm, "
      "volume %.6f (seen %.6f, upper %.6f, true %.6f)\n",
      c.depth_m * 1000, c.radius_m * 1000, c.z_m, rows, d.max_depth_seen_m * 1000, d.floor_visible ? "seen" : "hidden",
      d.max_depth_bound_m * 1000, d.volume_m3, d.volume_seen_m3, d.volume_upper_m3, scene.TrueVolumeM3());
  return d;
}

// The deep caps above with the disparity smoothed over 9 rows along the columns: the deepest
// seen part then begins ~3 rows behind the rim and reaches 9-11 rows from it, as far as a seen
// floor's; measured from the rim, both would read "seen" from 9 rows on,
// and the grazing depth taken within two rows of the rim (the road mixed in) would leave the 120 mm
// cap's bound at 101 mm. The flag, the lower bound and both upper bounds must still hold.
TEST(FloorVisibility, SmoothedDisparityHiddenFloor) {
  for (const Case& c : {Case{1.5, 15, 0.08, 0.15, 6.0}, Case{1.5, 15, 0.12, 0.15, 5.0}}) {
    const DamageInstance d = DetectSmoothed(c, 9);
    EXPECT_FALSE(d.floor_visible);
    EXPECT_LT(d.max_depth_seen_m, c.depth_m - 0.010);  // the smoothed frame shows much less
    EXPECT_LE(d.max_depth_seen_m - 2 * d.sigma_depth_m, c.depth_m);
    EXPECT_GE(d.max_depth_bound_m, c.depth_m);
    EXPECT_GE(d.volume_upper_m3, Scene(c).TrueVolumeM3());
    EXPECT_GE(d.max_depth_m, d.max_depth_seen_m);
    EXPECT_LE(d.max_depth_m, d.max_depth_bound_m);
  }
}
// Seen floors stay seen under the same smoothing (a wide shallow cap; a wide deep cap nearer).
TEST(FloorVisibility, SmoothedDisparitySeenFloor) {
  for (const Case& c : {Case{1.5, 15, 0.025, 0.3, 5.0}, Case{1.5, 15, 0.12, 0.35, 4.0}}) {
    const DamageInstance d = DetectSmoothed(c, 9);
    EXPECT_TRUE(d.floor_visible);
    EXPECT_NEAR(d.max_depth_m, c.depth_m, 0.010);
  }
}

}  // namespace
}  // namespace rs
