#include "sim/road_scene.h"

#include "sim/footprint_coverage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <vector>

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

/// A pinhole camera over the road: rays and their per-pixel differentials.
struct PinholeView {
  Eigen::Vector3d o;
  Eigen::Matrix3d R_world_cam;  // columns: image right, image down, optical axis
  double f = 1000;
  /// Unit ray through image point (u, v) (from the principal point) and its
  /// differentials for a pixel `size` pixels wide.
  Eigen::Vector3d Ray(double u, double v, double size, PixelDifferentials* px) const {
    const Eigen::Vector3d D = R_world_cam * Eigen::Vector3d(u / f, v / f, 1);
    const double k = 1.0 / D.norm();
    px->dd_du = R_world_cam.col(0) * (size * k / f);
    px->dd_dv = R_world_cam.col(1) * (size * k / f);
    return D * k;
  }
};

/// Camera `height_m` above the lane at (s, l), looking along the road `pitch_deg` down.
PinholeView ViewAlongRoad(const RoadScene& scene, double s, double l, double height_m, double pitch_deg) {
  PinholeView c;
  const Eigen::Vector2d xy = scene.road().ToWorld(s, l);
  c.o = Eigen::Vector3d(xy.x(), xy.y(), scene.road().IntactZ(s, l) + height_m);
  const double h = scene.road().HeadingRad(s), p = pitch_deg * M_PI / 180;
  const Eigen::Vector3d fwd(std::cos(h), std::sin(h), 0), up = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d x = fwd.cross(up), z = std::cos(p) * fwd - std::sin(p) * up;
  c.R_world_cam.col(0) = x;
  c.R_world_cam.col(1) = z.cross(x);
  c.R_world_cam.col(2) = z;
  return c;
}

/// Radiance of pixel (u, v) as the renderer shades it: one ray.
double RenderedPixel(const RoadScene& scene, const PinholeView& c, double u, double v) {
  PixelDifferentials px;
  const Eigen::Vector3d d = c.Ray(u, v, 1.0, &px);
  return scene.Cast(c.o, d, px).radiance;
}

/// What a real pixel records: the mean radiance over its square (box
/// integral), from 16 x 16 rays of 1/16-pixel footprints, fine enough that no
/// texture octave is filtered.
double BoxIntegratedPixel(const RoadScene& scene, const PinholeView& c, double u, double v) {
  constexpr int kSub = 16;
  double sum = 0;
  for (int i = 0; i < kSub; ++i) {
    for (int j = 0; j < kSub; ++j) {
      PixelDifferentials px;
      const Eigen::Vector3d d = c.Ray(u + (i + 0.5) / kSub - 0.5, v + (j + 0.5) / kSub - 0.5, 1.0 / kSub, &px);
      sum += scene.Cast(c.o, d, px).radiance;
    }
  }
  return sum / (kSub * kSub);
}

/// Row statistics of rendered pixels a against the box integral r: the ratio of
/// their RMS pixel-to-pixel differences (horizontal gradients) and the correlation.
struct RowAgreement {
  double gradient = 0, correlation = 0;
};
RowAgreement CompareRows(const std::vector<double>& a, const std::vector<double>& r) {
  const double ma = std::accumulate(a.begin(), a.end(), 0.0) / a.size();
  const double mr = std::accumulate(r.begin(), r.end(), 0.0) / r.size();
  double saa = 0, srr = 0, sar = 0, ga = 0, gr = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    saa += (a[i] - ma) * (a[i] - ma), srr += (r[i] - mr) * (r[i] - mr), sar += (a[i] - ma) * (r[i] - mr);
    if (i > 0) ga += (a[i] - a[i - 1]) * (a[i] - a[i - 1]), gr += (r[i] - r[i - 1]) * (r[i] - r[i - 1]);
  }
  return {std::sqrt(ga / gr), sar / std::sqrt(saa * srr)};
}

TEST(RoadScene, TextureFilterMatchesBoxPixel) {
  // A pixel records the mean radiance over its footprint, which from a
  // forward-looking camera is long along the view and narrow across it. Along
  // an image row (the horizontal gradients stereo matches on) the rendered
  // pixels must keep the texture the box integral keeps, as nadir pixels of the
  // same width do, without detail finer than the footprint (aliasing). The
  // former filter faded octaves by the footprint along the view: at 6 m ahead
  // of the car camera gradient 0.056, correlation -0.02; at 10 m 0.009, 0.08.
  SimulationOptions o;
  o.potholes_per_100m = o.cracks_per_100m = o.alligator_per_100m = o.patches_per_100m = 0;
  const RoadScene scene(o, 0, 40);
  struct Case {
    double height_m, pitch_deg, ahead_m;  // ahead_m: the row's distance ahead of the camera
    double min_gradient, min_correlation;
  };
  // Rows whose footprint is <= 6 mm across resolve the 9 mm stones: measured gradient 0.98-1.18, correlation
  // 0.94-0.99. At 10 m (10 mm across) the isotropic fade keeps little of them: nadir 0.26 / 0.75, car 0.37 / 0.80.
  const Case cases[] = {{1.5, 15, 3, 0.8, 0.9}, {1.5, 15, 6, 0.8, 0.9}, {1.5, 15, 10, 0.3, 0.7}, {4, 90, 0, 0.8, 0.9},
                        {4, 90, 4, 0.8, 0.9},   {6, 90, 0, 0.8, 0.9},   {10, 90, 0, 0.2, 0.65}};
  for (const Case& cs : cases) {
    const PinholeView c = ViewAlongRoad(scene, 5, 1.8, cs.height_m, cs.pitch_deg);
    const double v = c.f * std::tan(std::atan2(cs.height_m, cs.ahead_m) - cs.pitch_deg * M_PI / 180);
    std::vector<double> rendered, box, point;
    for (int u = -100; u < 100; ++u) {
      rendered.push_back(RenderedPixel(scene, c, u, v));
      box.push_back(BoxIntegratedPixel(scene, c, u, v));
      PixelDifferentials px;
      point.push_back(scene.Cast(c.o, c.Ray(u, v, 1.0 / 16, &px), px).radiance);
    }
    const RowAgreement q = CompareRows(rendered, box), unfiltered = CompareRows(point, box);
    std::printf(
        "camera %.1f m up, %.0f deg down, row %.0f m ahead: gradient %.3f, correlation %.3f "
        "(point sampled: gradient %.3f)\n",
        cs.height_m, cs.pitch_deg, cs.ahead_m, q.gradient, q.correlation, unfiltered.gradient);
    EXPECT_GE(q.gradient, cs.min_gradient) << cs.ahead_m << " m ahead, " << cs.height_m << " m up";
    EXPECT_GE(q.correlation, cs.min_correlation) << cs.ahead_m << " m ahead, " << cs.height_m << " m up";
    // Aliasing: more pixel-to-pixel change than the box integral has. Unfiltered
    // point samples of the car rows reach 1.3-2.7 (the bound catches them).
    EXPECT_LE(q.gradient, 1.3) << cs.ahead_m << " m ahead, " << cs.height_m << " m up";
    if (cs.pitch_deg < 45 && cs.ahead_m >= 6) {
      EXPECT_GT(unfiltered.gradient, 1.5);
    }
  }
}

TEST(RoadScene, FootprintCoverageMatchesRotatedBox) {
  // The trapezoid CDF against the fraction of a rotated 30 x 10 mm box, sampled
  // on a 400 x 400 grid, lying at or below x on the axis; and a row across a
  // strip integrates to its width.
  const double w1 = 0.03, w2 = 0.01, ang = 0.5;
  const double a = w1 * std::abs(std::cos(ang)), b = w2 * std::abs(std::sin(ang));
  for (double x : {-0.02, -0.012, -0.004, 0.0, 0.003, 0.011, 0.018}) {
    int below = 0;
    constexpr int kN = 400;
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN; ++j) {
        const double p = ((i + 0.5) / kN - 0.5) * w1, q = ((j + 0.5) / kN - 0.5) * w2;
        below += p * std::cos(ang) + q * std::sin(ang) <= x;
      }
    EXPECT_NEAR(BoxProjectionCdf(x, a, b), below / double(kN * kN), 0.003) << x;
  }
  double sum = 0;
  const double dx = 1e-4;
  for (double x = -0.2; x < 0.2; x += dx) sum += StripCoverage(x, -0.06, 0.06, a, b) * dx;
  EXPECT_NEAR(sum, 0.12, 1e-6);
}

TEST(RoadScene, PaintEdgesMatchBoxPixel) {
  // A pixel straddling a paint edge records the paint in proportion to its
  // coverage, as the box integral of 16 x 16 sub-pixels does, and a row across
  // the 0.15 m edge line records its painted width. Paint share of a pixel:
  // radiance with markings minus without, averaged over 40 rows along the
  // line (the 9 mm stones make single pixels vary by ~30 %), over that of the
  // columns fully inside. The former point test made each edge a hard step at
  // the pixel centre: shares of 0 or 1 where the box gives 0.5 (checked below
  // on point samples).
  SimulationOptions o;
  o.potholes_per_100m = o.cracks_per_100m = o.alligator_per_100m = o.patches_per_100m = 0;
  o.parked_cars = o.people = 0;
  const RoadScene scene(o, 0, 40);
  o.lane_markings = false;
  const RoadScene bare(o, 0, 40);
  const double line_l = scene.road().half_width() - 0.3;
  constexpr int kCols = 6, kRows = 40;  // columns -kCols..kCols; the line spans 7.5 columns
  double worst = 0, worst_point = 0;
  for (double shift : {0.0, 0.005, 0.01, 0.015}) {  // the line's position within a 2 cm pixel
    PinholeView c = ViewAlongRoad(scene, 7, line_l + shift, 4, 90);
    c.f = 200;  // 2 cm pixels
    std::vector<double> rendered(2 * kCols + 1), box(2 * kCols + 1), point(2 * kCols + 1);
    for (int u = -kCols; u <= kCols; ++u) {
      for (int v = -kRows / 2; v < kRows / 2; ++v) {
        rendered[u + kCols] += RenderedPixel(scene, c, u, v) - RenderedPixel(bare, c, u, v);
        box[u + kCols] += BoxIntegratedPixel(scene, c, u, v) - BoxIntegratedPixel(bare, c, u, v);
        PixelDifferentials px;
        const Eigen::Vector3d d = c.Ray(u, v, 1.0 / 16, &px);
        point[u + kCols] += scene.Cast(c.o, d, px).radiance - bare.Cast(c.o, d, px).radiance;
      }
    }
    // Shares: over the mean of the columns within +-2 of the line centre (always fully painted).
    auto shares = [&](std::vector<double>& x) {
      double inside = 0;
      for (int u = -2; u <= 2; ++u) inside += x[u + kCols] / 5;
      double sum = 0;
      for (double& e : x) sum += (e /= inside);
      return sum;
    };
    const double width_r = shares(rendered), width_box = shares(box), width_point = shares(point);
    double err = 0, err_point = 0;
    for (int k = 0; k <= 2 * kCols; ++k) {
      err = std::max(err, std::abs(rendered[k] - box[k]));
      err_point = std::max(err_point, std::abs(point[k] - box[k]));
    }
    std::printf(
        "line shifted %.3f m: painted width rendered %.3f, box %.3f, point sampled %.3f px (true 7.5); "
        "largest share error %.3f (point sampled %.3f)\n",
        shift, width_r, width_box, width_point, err, err_point);
    EXPECT_NEAR(width_r, 7.5, 0.1) << shift;
    EXPECT_NEAR(width_box, 7.5, 0.1) << shift;
    worst = std::max(worst, err), worst_point = std::max(worst_point, err_point);
  }
  // Measured 0.047-0.059 (texture left after 40 rows), point samples 0.08-0.28.
  EXPECT_LE(worst, 0.08);
  EXPECT_GT(worst_point, 0.2);
}

TEST(RoadScene, ShadowPenumbraFollowsSunDisc) {
  // A parked car's shadow edge on the road, seen from straight above by rays of
  // 0.03 mm footprints: the sun's visible fraction (radiance with / without
  // shadows) ramps from 0.25 to 0.75 over 0.404 x D x tan(0.53 deg), D the
  // distance from the road to the occluding roof edge (25-75 % width of a
  // uniform disc behind a straight edge), centred where the ray to the sun's
  // centre grazes that edge. The former single shadow ray: a step.
  SimulationOptions o;
  o.potholes_per_100m = o.cracks_per_100m = o.alligator_per_100m = o.patches_per_100m = 0;
  o.parked_cars = 1;
  o.people = 0;
  const RoadScene scene(o, 0, 40);
  o.shadows = false;
  const RoadScene unshadowed(o, 0, 40);
  ASSERT_EQ(scene.obstacles().size(), 1u);
  const Obstacle& car = scene.obstacles()[0];
  ASSERT_EQ(car.kind, Obstacle::Kind::kBox);
  const Eigen::Vector3d sun = scene.lighting().sun_world;
  // The box's horizontal axis pointing most directly away from the sun: the roof edge across it casts the edge.
  int k = 0;
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  for (int i = 0; i < 2; ++i) {
    Eigen::Vector3d ax = car.R_world_obj.col(i);
    if (ax.dot(sun) > 0) ax = -ax;
    if (-ax.dot(sun) > -axis.dot(sun)) axis = ax, k = i;
  }
  const double z_top = car.centre.z() + car.half_size.z();
  const double z_road = scene.IntactHeightAt(car.centre.x(), car.centre.y());
  // Walk along axis through the shadow of the roof's centre, across its far edge.
  const Eigen::Vector3d c0 = car.centre + Eigen::Vector3d(0, 0, car.half_size.z()) - (z_top - z_road) / sun.z() * sun;
  double s25 = NAN, s75 = NAN;
  for (double s = car.half_size[k] - 0.4; s < car.half_size[k] + 0.4; s += 0.0005) {
    const Eigen::Vector3d q = c0 + s * axis;
    const Eigen::Vector3d o3(q.x(), q.y(), z_road + 30), d(0, 0, -1);
    const RayHit h = scene.Cast(o3, d, 1e-6), h0 = unshadowed.Cast(o3, d, 1e-6);
    ASSERT_TRUE(h.hit && h.road);
    const double vis = (h.radiance / h0.radiance - scene.lighting().ambient) / (1 - scene.lighting().ambient);
    if (std::isnan(s25) && vis >= 0.25) s25 = s;
    if (std::isnan(s75) && vis >= 0.75) s75 = s;
  }
  ASSERT_FALSE(std::isnan(s25) || std::isnan(s75));
  // Where the sun's centre grazes the roof edge from the penumbra's middle (the road there is not at z_road:
  // camber, kerb), and the distance D to it.
  const Eigen::Vector3d q = c0 + 0.5 * (s25 + s75) * axis;
  const double z_q = scene.HeightAt(q.x(), q.y());
  const double D = (z_top - z_q) / sun.z();
  const double edge = (Eigen::Vector3d(q.x(), q.y(), z_q) + D * sun - car.centre).dot(axis);
  const double expected = 0.404 * D * std::tan(0.53 * M_PI / 180);
  std::printf(
      "roof edge %.2f m from the road: penumbra 25-75 %% %.1f mm (uniform disc %.1f mm), its middle's sun "
      "ray %.1f mm from the roof edge\n",
      D, 1e3 * (s75 - s25), 1e3 * expected, 1e3 * (edge - car.half_size[k]));
  EXPECT_NEAR(s75 - s25, expected, 0.25 * expected);
  EXPECT_NEAR(edge, car.half_size[k], 0.003);
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
