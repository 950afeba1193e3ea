#include "stages/damage/floor_visibility.h"

#include "stages/damage/damage_output.h"
#include "stages/damage/damage_pipeline.h"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
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
      const Eigen::Vector3d p((u - s.geometry.cx_px) * z / s.geometry.f_px, (v - s.geometry.cy_px) * z / s.geometry.f_px, z);
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
  std::printf("cap %.0f mm / %.0f mm at %.1f m, pitch %.0f: visible %.1f mm (hidden %.1f), measured %.1f mm, "
              "sigma_Z %.1f mm, e %.1f deg (truth %.1f), floor %s, bound %.1f mm, volume %.6f (upper %.6f, true %.6f)\n",
              c.depth_m * 1000, c.radius_m * 1000, c.z_m, c.pitch_deg, truth.visible_depth_m * 1000, hidden_m * 1000,
              d.max_depth_m * 1000, d.sigma_depth_m * 1000, d.grazing_angle_deg,
              std::atan(truth.tan_rim) * 180 / CV_PI, d.floor_visible ? "seen" : "hidden", d.max_depth_bound_m * 1000,
              d.volume_m3, d.volume_upper_m3, scene.TrueVolumeM3());
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
// tolerance (the test of the completion, not of the measurement). Measured (session 6): 80 mm
// cap 81.9 mm, −6.7 % (seen 59 mm, −44 %); 120 mm cap 120.9 mm, −14.4 % (seen 77 mm, −54 %:
// close to the 15 % bound; the area is −3 %); wedge case −3.7 % (seen −9.0 %, area −3.5 %).
void ExpectEstimate(const Case& c, const DamageInstance& d, double volume_tol, double depth_tol_m) {
  const double v = Scene(c).TrueVolumeM3();
  std::printf("  estimate: depth %.1f mm (seen %.1f, true %.1f), volume %.6f (seen %.6f, true %.6f): %+.1f %% (seen %+.1f %%), "
              "area %+.1f %%\n", d.max_depth_m * 1000, d.max_depth_seen_m * 1000, c.depth_m * 1000, d.volume_m3,
              d.volume_seen_m3, v, 100 * (d.volume_m3 / v - 1), 100 * (d.volume_seen_m3 / v - 1),
              100 * (d.area_m2 / Scene(c).TrueAreaM2() - 1));
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
  ExpectEstimate(c, Check(c, false), 0.15, 0.010);
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
  std::printf("cap %.0f mm / %.0f mm at %.1f m, smoothed over %d rows: seen %.1f mm, floor %s, bound %.1f mm, "
              "volume %.6f (seen %.6f, upper %.6f, true %.6f)\n",
              c.depth_m * 1000, c.radius_m * 1000, c.z_m, rows, d.max_depth_seen_m * 1000,
              d.floor_visible ? "seen" : "hidden", d.max_depth_bound_m * 1000, d.volume_m3, d.volume_seen_m3,
              d.volume_upper_m3, scene.TrueVolumeM3());
  return d;
}

// The deep caps above with the disparity smoothed over 9 rows along the columns: the deepest
// seen part then begins ~3 rows behind the rim and reaches 9-11 rows from it, as far as a seen
// floor's; measured from the rim (the flag before session 7) both read "seen" from 9 rows on,
// and the grazing depth taken within two rows of the rim (the road mixed in) left the 120 mm
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
