#include "stages/simulate/road_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

namespace rs::sim {
namespace {

SimulationOptions SceneOptions() {
  SimulationOptions o;
  o.seed = 5;
  o.potholes_per_100m = 60;
  o.cracks_per_100m = 30;
  o.alligator_per_100m = 10;
  o.patches_per_100m = 10;
  o.parked_cars = 1;
  o.people = 1;
  return o;
}

TEST(RoadGeometry, Nominal) {
  for (double curvature : {0.0, 0.004, -0.01}) {
    SimulationOptions o;
    o.road_curvature_1_m = curvature;
    const RoadGeometry road(o);
    for (double s : {0.0, 7.5, 40.0}) {
      for (double l : {-4.0, 0.0, 2.5}) {
        const Eigen::Vector2d p = road.ToWorld(s, l);
        double s2, l2;
        road.ToRoad(p.x(), p.y(), &s2, &l2);
        EXPECT_NEAR(s2, s, 1e-9);
        EXPECT_NEAR(l2, l, 1e-9);
      }
    }
    // Arc length: 1 mm of s on the centreline is 1 mm in the world.
    EXPECT_NEAR((road.ToWorld(20.001, 0) - road.ToWorld(20, 0)).norm(), 0.001, 1e-9);
    // The road starts at the origin with the configured compass bearing (30 deg: north-north-east).
    const Eigen::Vector2d dir = road.ToWorld(1e-3, 0) / 1e-3;
    EXPECT_NEAR(std::atan2(dir.x(), dir.y()) * 180 / M_PI, 30.0, 1e-3);
  }
}

TEST(RoadScene, PotholeVolumeMatchesHeightfield) {
  // The reported volume/area/depth must equal an independent integration of the
  // rendered surface (intact minus true height) on a world-axis grid at 2 mm.
  const SimulationOptions o = SceneOptions();
  const RoadScene scene(o, 5, 25);
  int potholes = 0;
  for (const Damage& d : scene.damages()) {
    if (d.type != DamageType::kPothole) continue;
    ++potholes;
    double xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
    for (double s : {d.s0, d.s_max()}) {
      for (double l : {d.l0, d.l_max()}) {
        const Eigen::Vector2d p = scene.road().ToWorld(s, l);
        xmin = std::min(xmin, p.x()), xmax = std::max(xmax, p.x());
        ymin = std::min(ymin, p.y()), ymax = std::max(ymax, p.y());
      }
    }
    const double h = 0.002;
    double vol = 0, area = 0, max_def = 0;
    for (double y = ymin + h / 2; y < ymax; y += h) {
      for (double x = xmin + h / 2; x < xmax; x += h) {
        const double def = scene.IntactHeightAt(x, y) - scene.HeightAt(x, y);
        if (def > 0) vol += def * h * h, max_def = std::max(max_def, def);
        if (scene.LabelAt(x, y) == d.id) area += h * h;
      }
    }
    EXPECT_NEAR(vol, d.volume_m3, 0.02 * d.volume_m3 + 2e-7) << "pothole " << d.id;
    EXPECT_NEAR(area, d.area_m2, 0.03 * d.area_m2) << "pothole " << d.id;
    EXPECT_NEAR(max_def, d.max_depth_m, 0.002) << "pothole " << d.id;
    EXPECT_GE(d.max_depth_m, 0.010);
    EXPECT_LE(d.max_depth_m, 0.14);
    EXPECT_GE(d.mean_diameter_m, 0.12);
    EXPECT_LE(d.mean_diameter_m, 1.6);
    EXPECT_NEAR(d.mean_depth_m * d.area_m2, d.volume_m3, 0.05 * d.volume_m3);
  }
  EXPECT_GE(potholes, 5);
}

TEST(RoadScene, DamageStaysInView) {
  const SimulationOptions o = SceneOptions();
  const RoadScene scene(o, 5, 25);
  ASSERT_GE(scene.damages().size(), 10u);
  for (const Damage& d : scene.damages()) {
    EXPECT_GE(d.s0, 5 - 0.05);
    EXPECT_LE(d.s_max(), 25 + 0.05);
    EXPECT_GE(d.l0, -o.road_width_m / 2);
    EXPECT_LE(d.l_max(), o.road_width_m / 2);
    EXPECT_LE(d.res, 0.005);
    if (d.type == DamageType::kCrackLongitudinal || d.type == DamageType::kCrackTransverse) {
      EXPECT_GE(d.width_m, 0.002);
      EXPECT_LE(d.width_m, 0.025);
      // A crack's volume is its depth profile times its width (coverage is anti-aliased).
      EXPECT_NEAR(d.volume_m3 / (d.length_m * d.width_m), d.max_depth_m, 0.4 * d.max_depth_m + 0.003);
    }
  }
  EXPECT_EQ(scene.obstacles().size(), 2u);
}

TEST(RoadScene, RayHitsSurface) {
  const SimulationOptions o = SceneOptions();
  const RoadScene scene(o, 5, 25);
  // Rays from 6 m up at various angles land on the true surface.
  for (double ax : {-0.5, 0.0, 0.3}) {
    for (double ay : {-0.4, 0.1}) {
      const Eigen::Vector2d c = scene.road().ToWorld(15, 0.5);
      const Eigen::Vector3d origin(c.x(), c.y(), 8.0);
      const Eigen::Vector3d d = Eigen::Vector3d(ax, ay, -1).normalized();
      const RayHit h = scene.Cast(origin, d, 1e-3);
      ASSERT_TRUE(h.hit);
      EXPECT_NEAR(h.p_world.z(), scene.HeightAt(h.p_world.x(), h.p_world.y()), 1e-4);
    }
  }
  // Grazing rays over the kerb (car view) still find the first surface crossing.
  const Eigen::Vector2d c = scene.road().ToWorld(10, 0);
  const Eigen::Vector3d origin(c.x(), c.y(), scene.road().IntactZ(10, 0) + 1.5);
  const double hd = scene.road().HeadingRad(10) + 1.3;
  const Eigen::Vector3d d = Eigen::Vector3d(std::cos(hd), std::sin(hd), -0.35).normalized();
  const RayHit h = scene.Cast(origin, d, 1e-3);
  ASSERT_TRUE(h.hit);
  EXPECT_NEAR(h.p_world.z(), scene.HeightAt(h.p_world.x(), h.p_world.y()), 1e-3);
  for (double t = 0.05; t < h.t - 0.02; t += 0.01) {
    const Eigen::Vector3d p = origin + t * d;
    EXPECT_GT(p.z(), scene.HeightAt(p.x(), p.y()) - 1e-4) << "ray passes below the surface at t=" << t;
  }
}

TEST(RoadScene, NeighbourGuessFindsFirstCrossing) {
  // The renderer starts each ray on the previous pixel's road tangent plane.
  // Sweep rows of rays across every damage, nadir-like and grazing (car-like):
  // hits lie on the surface, the guess never yields a farther crossing than the
  // search without it, and it finds the first crossing (the ray stays above the
  // surface before the hit) at least as often, for >= 99 % of the rays.
  const SimulationOptions o = SceneOptions();
  const RoadScene scene(o, 5, 25);
  auto is_first = [&](const Eigen::Vector3d& origin, const Eigen::Vector3d& d, double t_hit) {
    // Rays descend >= 10 deg here: 2 m before the hit they are far above any surface.
    for (double t = std::max(0.0, t_hit - 2.0); t < t_hit - 2e-4; t += 2e-4) {
      const Eigen::Vector3d p = origin + t * d;
      if (p.z() < scene.HeightAt(p.x(), p.y()) - 1e-6) return false;
    }
    return true;
  };
  int road_rays = 0, guessed = 0, first_guess = 0, first_plain = 0;
  for (const Damage& dm : scene.damages()) {
    for (const double back : {2.0, 8.0}) {
      const double sc = 0.5 * (dm.s0 + dm.s_max()), lc = 0.5 * (dm.l0 + dm.l_max());
      const Eigen::Vector2d c = scene.road().ToWorld(sc - back, lc + 1.0);
      const Eigen::Vector3d origin(c.x(), c.y(), scene.road().IntactZ(sc, lc) + 1.5);
      const Eigen::Vector2d target = scene.road().ToWorld(sc, lc);
      RayHit prev;
      for (int u = -60; u <= 60; u += 2) {
        const Eigen::Vector2d side = scene.road().ToWorld(sc + 0.01 * u, lc - 0.01 * u) - target;
        const Eigen::Vector3d to(target.x() + side.x(), target.y() + side.y(), scene.road().IntactZ(sc, lc));
        const Eigen::Vector3d d = (to - origin).normalized();
        const double guess = prev.StartOnPlane(origin, d);
        const RayHit h = scene.Cast(origin, d, 1e-3, std::numeric_limits<double>::quiet_NaN(), guess);
        const RayHit h0 = scene.Cast(origin, d, 1e-3);
        prev = h;
        ASSERT_TRUE(h.hit);
        EXPECT_LE(h.t, h0.t + 1e-4) << "the guess found a farther crossing than the search without it";
        if (!h.road || !h0.road) continue;  // the parked car or the person
        ++road_rays;
        guessed += std::isnan(guess) ? 0 : 1;
        EXPECT_NEAR(h.p_world.z(), scene.HeightAt(h.p_world.x(), h.p_world.y()), 2e-5);
        first_guess += is_first(origin, d, h.t) ? 1 : 0;
        first_plain += is_first(origin, d, h0.t) ? 1 : 0;
      }
    }
  }
  std::printf("%d road rays, %d with a guess; first crossing found: %d with the guess, %d without\n", road_rays,
              guessed, first_guess, first_plain);
  EXPECT_GT(guessed, road_rays * 9 / 10);
  EXPECT_GE(first_guess, first_plain);
  EXPECT_GE(first_guess, road_rays * 99 / 100) << road_rays << " rays";
}

TEST(NoiseTable, StoneMean) {
  // BaseAlbedo fades unresolved stones to their mean (kStoneMean = 0.227).
  const NoiseTable t(123);
  double sum = 0;
  const int n = 200000;
  Rng rng(1);
  for (int i = 0; i < n; ++i) {
    const double v = t.Sample(rng.Uniform(0, 1024), rng.Uniform(0, 1024));
    const double x = std::clamp((v - 0.58) / 0.16, 0.0, 1.0);
    sum += x * x * (3 - 2 * x);
  }
  EXPECT_NEAR(sum / n, 0.227, 0.01);
}

}  // namespace
}  // namespace rs::sim
