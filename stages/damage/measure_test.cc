#include "stages/damage/measure.h"

#include "stages/damage/damage_pipeline.h"

#include <gtest/gtest.h>

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
  // σ_Z = Z²σ_d/(fB) at the pothole's range.
  EXPECT_NEAR(d.sigma_depth_m, d.range_m * d.range_m * 0.25 / (1000 * 0.2), 1e-9);
  EXPECT_NEAR(d.range_m, z_m, 0.1 * z_m);
  // The camera-frame outline lies on the road plane, around the centre.
  ASSERT_GT(d.outline_cam_m.size(), 8u);
}

TEST(MeasureDepressions, Nominal) { CheckCap(0.06, 0.25, 2.2); }
TEST(MeasureDepressions, ShallowWide) { CheckCap(0.035, 0.40, 2.5); }
TEST(MeasureDepressions, DeepSmall) { CheckCap(0.08, 0.15, 1.9); }

TEST(MeasureDepressions, WrongLabelType) {
  SyntheticRoadScene scene;
  RoadRelief r;
  r.depth_below_mm = cv::Mat::zeros(10, 10, CV_32F);
  EXPECT_THROW(MeasureDepressions(cv::Mat::zeros(10, 10, CV_8U), r, scene.geometry, RoadSurface(), MeasureOptions()),
               std::invalid_argument);
}

}  // namespace
}  // namespace rs
