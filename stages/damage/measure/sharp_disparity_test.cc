#include "stages/damage/measure/sharp_disparity.h"
#include "sim/synthetic_damage_scene.h"

#include "stages/damage/damage_pipeline.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>

namespace rs {
namespace {

// A pothole seen through a spreading disparity (its walls blurred onto the road and the floor
// pulled up, as the disparity stage's 21x21 smooth window does) and through a sharp one (the
// small window's image: the true walls, more per-pixel noise). Given the sharp image, the volume
// is summed on it; the outline, the detection and the max depth stay the smooth image's.
TEST(SharpDisparity, VolumeSummedOnTheSharpImage) {
  SyntheticRoadScene scene;
  scene.pothole_radius_m = 0.15, scene.pothole_depth_m = 0.05, scene.pothole_z_m = 2.2;
  scene.sigma_d_px = 0.08;  // the small window's noise
  const cv::Mat sharp = scene.Render();
  SyntheticRoadScene flat = scene;
  flat.pothole_depth_m = 0, flat.sigma_d_px = 0;
  const cv::Mat road = flat.Render();
  // The smooth image: the depression (disparity below the road) blurred over 15x15 and 15 %
  // shallower (the floor beside a wall pulled up).
  cv::Mat smooth;
  cv::blur(sharp - road, smooth, cv::Size(15, 15), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  smooth = road + 0.85 * smooth;
  smooth.setTo(0, sharp <= 0);
  const DamageOptions o;
  const FrameDamage one = DetectDamage(smooth, cv::Mat(), scene.geometry, o);
  const FrameDamage two = DetectDamage(smooth, cv::Mat(), scene.geometry, o, sharp);
  ASSERT_EQ(one.instances.size(), 1u);
  ASSERT_EQ(two.instances.size(), 1u);
  const DamageInstance &a = one.instances[0], &b = two.instances[0];
  const double volume = scene.TrueVolumeM3();
  const double vol_one = 100 * (a.volume_m3 / volume - 1), vol_two = 100 * (b.volume_m3 / volume - 1);
  std::printf("volume error: smooth only %+.1f %%, summed on the sharp image %+.1f %% (area %+.1f %%)\n", vol_one,
              vol_two, 100 * (b.area_m2 / scene.TrueAreaM2() - 1));
  EXPECT_LT(vol_one, -10) << "the premise: the smooth image lifts the floor";
  EXPECT_LT(std::abs(vol_two), 5);
  // The rest is the smooth image's: the same outline, type and max depth (15 % short here).
  EXPECT_EQ(cv::countNonZero(one.labels != two.labels), 0);
  EXPECT_EQ(a.type, b.type);
  EXPECT_EQ(a.area_m2, b.area_m2);
  EXPECT_EQ(a.max_depth_m, b.max_depth_m);
  EXPECT_LT(b.max_depth_m, 0.9 * scene.pothole_depth_m);
}

// The depth below the road on the sharp image equals the relief's unsmoothed depth where the two
// images agree (both the same disparity), NaN off the labels.
TEST(SharpDisparity, DepthEqualsTheReliefsBeforeSmoothing) {
  const SyntheticRoadScene scene;
  const cv::Mat d = scene.Render();
  const FrameDamage f = DetectDamage(d, cv::Mat(), scene.geometry, DamageOptions());
  ASSERT_FALSE(f.instances.empty());
  const RoadRelief evaluated = EvaluateRoadModel(d, scene.geometry, f.surface, DamageOptions().road);
  const cv::Mat sharp = SharpDepthBelowMm(d, d, f.labels, scene.geometry, f.surface, f.relief.correction_mm);
  double worst = 0;
  int n = 0;
  for (int v = 0; v < d.rows; ++v)
    for (int u = 0; u < d.cols; ++u) {
      const float x = sharp.at<float>(v, u);
      if (!f.labels.at<uint16_t>(v, u)) {
        EXPECT_TRUE(std::isnan(x));
        continue;
      }
      const float ref = evaluated.depth_below_mm.at<float>(v, u) - f.relief.correction_mm.at<float>(v, u);
      if (!std::isfinite(ref)) continue;
      worst = std::max(worst, std::abs(double(x) - ref)), ++n;
    }
  EXPECT_GT(n, 1000);
  EXPECT_LT(worst, 1e-3);  // mm: float rounding only
}

TEST(SharpDisparity, WrongSize) {
  const SyntheticRoadScene scene;
  const cv::Mat d = scene.Render();
  EXPECT_THROW(DetectDamage(d, cv::Mat(), scene.geometry, DamageOptions(), cv::Mat(10, 10, CV_32F, cv::Scalar(1))),
               std::invalid_argument);
}

}  // namespace
}  // namespace rs
