#pragma once
// The simulated world: a curved, sloped, cambered road with kerbs and verges,
// damage (potholes, cracks, alligator cracking, repair patches) as fine
// heightfield patches, and obstacles. World frame: local ENU (x east, y north,
// z up, metres) at the geodetic origin. Road coordinates (s, l): s = arc length
// along the centreline from its start, l = lateral offset, positive to the left
// of the direction of increasing s.

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sim/sim_random.h"
#include "sim/simulation_options.h"

namespace rs::sim {

/// Centreline geometry: a circular arc (or straight line) with grade and camber.
class RoadGeometry {
 public:
  explicit RoadGeometry(const SimulationOptions& o);

  /// ENU heading of the centreline at s, rad counter-clockwise from east.
  double HeadingRad(double s) const { return heading0_ + curvature_ * s; }
  /// World x, y of road point (s, l).
  Eigen::Vector2d ToWorld(double s, double l) const;
  /// Road coordinates of world (x, y); optionally the centreline direction (cos, sin of the heading) at s.
  void ToRoad(double x, double y, double* s, double* l, double* cos_h = nullptr, double* sin_h = nullptr) const;
  /// d(arc length at offset l)/ds: distances along s shrink by this factor at offset l.
  double Stretch(double l) const { return 1.0 - curvature_ * l; }

  /// Intact surface height (grade, camber, kerb, verge) and its road-coordinate gradient.
  double IntactZ(double s, double l, double* dz_ds = nullptr, double* dz_dl = nullptr) const;
  /// Smooth approximation used to start ray casts: grade and camber only.
  double SmoothZ(double s, double l) const { return grade_ * s - crossfall_ * std::abs(l); }

  double half_width() const { return half_width_; }
  double kerb_width() const { return 0.15; }
  double curvature() const { return curvature_; }

 private:
  double heading0_, curvature_, grade_, crossfall_, half_width_, kerb_height_;
  double cos0_, sin0_;      // direction of the centreline at s = 0
  double rho_;              // signed radius 1 / curvature_ (0 when straight)
  Eigen::Vector2d centre_;  // centre of the arc (unused when straight)
};

enum class DamageType { kPothole, kCrackLongitudinal, kCrackTransverse, kAlligator, kPatch };
const char* ToString(DamageType t);

/// One damage with its fine heightfield patch and its true measurements.
struct Damage {
  int id = 0;  ///< instance id in masks and GeoJSON (1..N)
  DamageType type = DamageType::kPothole;
  /// Outline (polygon, not closed) for areas; centreline polyline for cracks. Road coordinates (s, l).
  std::vector<Eigen::Vector2d> outline_sl;
  double width_m = 0;          ///< crack width (cracks, alligator)
  double length_m = 0;         ///< crack length (cracks)
  double area_m2 = 0;          ///< pothole/patch/alligator: area inside the outline; cracks: length x width
  double max_depth_m = 0;      ///< largest height deficit of the heightfield
  double mean_depth_m = 0;     ///< volume / area of cells with a deficit
  double volume_m3 = 0;        ///< integral of the height deficit over the surface
  double mean_diameter_m = 0;  ///< potholes: diameter of the circle of equal area
  std::string severity;        ///< "L", "M", "H" (ASTM D6433 potholes, FHWA LTPP cracks)
  std::string severity_standard;

  // Patch grid in road coordinates: cell (i, j) centre = (s0 + (i + .5) res, l0 + (j + .5) res).
  double s0 = 0, l0 = 0, res = 0.004;
  int ns = 0, nl = 0;
  std::vector<float> deficit_m;   ///< height below the intact surface (< 0: raised), per cell, row j major
  std::vector<float> albedo_mul;  ///< albedo multiplier per cell
  std::vector<uint8_t> mask;      ///< 1 where the cell belongs to the damage
  double s_max() const { return s0 + ns * res; }
  double l_max() const { return l0 + nl * res; }
};

/// A box (parked car) or vertical cylinder (person).
struct Obstacle {
  enum class Kind { kBox, kCylinder } kind = Kind::kBox;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< box centre / cylinder base centre, world
  Eigen::Matrix3d R_world_obj = Eigen::Matrix3d::Identity();
  Eigen::Vector3d half_size = Eigen::Vector3d::Ones();  ///< box half extents; cylinder (radius, radius, height)
  float albedo = 0.3f;
  std::string name;
};

/// Result of a ray cast.
struct RayHit {
  bool hit = false;
  double t = 0;                                       ///< ray parameter (ray direction unit length: metres)
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  ///< hit point
  float radiance = 0;                                 ///< shaded brightness in [0, ~1.5] before camera effects
  uint16_t label = 0;                                 ///< damage id or 0
  /// Road hits: the tangent plane of the intact (undamaged) surface at the hit,
  /// z = intact_z + intact_grad . (xy - p_world.xy). A neighbouring pixel's ray
  /// meets the road within micrometres of this plane (StartOnPlane).
  bool road = false;
  double intact_z = 0;
  Eigen::Vector2d intact_grad = Eigen::Vector2d::Zero();

  /// Ray parameter where ray (o, d) meets this hit's intact tangent plane, NaN
  /// when there is none (no road hit, ray not descending onto the plane).
  double StartOnPlane(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const;
};

/// How a pixel's ray direction changes per pixel step along the image columns
/// (u) and rows (v), the ray differentials: the pixel's footprint on the
/// surface it hits follows from them. Components along the ray do not matter.
struct PixelDifferentials {
  Eigen::Vector3d dd_du = Eigen::Vector3d::Zero();
  Eigen::Vector3d dd_dv = Eigen::Vector3d::Zero();
  /// A square pixel of angular size pixel_angle_rad, of a camera without roll
  /// looking along the unit direction d (image rows horizontal).
  static PixelDifferentials Square(const Eigen::Vector3d& d, double pixel_angle_rad);
};

/// Parameters that describe the rendered appearance.
struct Lighting {
  Eigen::Vector3d sun_world;  ///< unit vector towards the sun
  double ambient = 0.35;
  double exposure = 2.0;
  bool shadows = true;
};

/// The whole scene. Immutable after construction, safe to query from many threads.
class RoadScene {
 public:
  /// Builds road, damage (placed along [s_view_min, s_view_max]) and obstacles from o.seed.
  RoadScene(const SimulationOptions& o, double s_view_min, double s_view_max);

  const RoadGeometry& road() const { return road_; }
  const std::vector<Damage>& damages() const { return damages_; }
  const std::vector<Obstacle>& obstacles() const { return obstacles_; }
  const Lighting& lighting() const { return lighting_; }

  /// True surface height at world (x, y) (intact surface minus damage deficit).
  double HeightAt(double x, double y) const;
  /// Intact (undamaged) surface height at world (x, y).
  double IntactHeightAt(double x, double y) const;
  /// Damage id at world (x, y), 0 if none.
  int LabelAt(double x, double y) const;

  /// Casts a ray (origin o, unit direction d) against road and obstacles and
  /// shades the hit. pixel: the pixel's ray differentials; the road texture is
  /// filtered over the pixel's footprint (long along the view at grazing angles,
  /// see BaseAlbedo). z_start: surface height to start the search at (NaN: the
  /// smooth road under o). t_guess: a ray parameter near the hit
  /// (RayHit::StartOnPlane of a neighbouring pixel), used when it lies on or
  /// above the surface; the hit found is the same surface point to within the
  /// solver tolerance (10 um in height).
  RayHit Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const PixelDifferentials& pixel,
              double z_start = std::numeric_limits<double>::quiet_NaN(),
              double t_guess = std::numeric_limits<double>::quiet_NaN()) const;
  /// The same for a square pixel of angular size pixel_angle_rad of a camera without roll.
  RayHit Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double pixel_angle_rad,
              double z_start = std::numeric_limits<double>::quiet_NaN(),
              double t_guess = std::numeric_limits<double>::quiet_NaN()) const {
    return Cast(o, d, PixelDifferentials::Square(d, pixel_angle_rad), z_start, t_guess);
  }

 private:
  struct SurfaceSample {
    double z = 0, dz_ds = 0, dz_dl = 0;
    double intact_z = 0, intact_dz_ds = 0, intact_dz_dl = 0;
    const Damage* damage = nullptr;
    double fi = 0, fj = 0;  // continuous cell coordinates inside the damage patch
  };
  SurfaceSample Surface(double s, double l) const;
  /// Bounded march along the ray from above the road near (s, l), then bisection:
  /// the first crossing where Newton cannot converge (kerb faces, pothole walls).
  bool MarchToSurface(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range, double* t, double* s,
                      double* l, double* ch, double* sh, SurfaceSample* S) const;
  const Damage* DamageAt(double s, double l) const;
  /// Texture samples per octave along a footprint's long axis, at most: the
  /// ratio of the footprint's sides reaches 8 at 12 m from a car camera 1.5 m
  /// up, beyond the damage stage's analysed range (7.7 m); farther, octaves
  /// fade by the longer per-sample box instead of costing more samples.
  static constexpr int kMaxAnisotropy = 8;
  /// A second sample is taken only when the footprint is longer than this
  /// times the spacing an octave needs: nadir views (sides within a few %)
  /// keep one sample per octave; the fade accounts for the exact length.
  static constexpr double kAnisoTolerance = 1.2;
  /// A pixel's footprint on the road in road coordinates: a box major_m long
  /// along the unit axis (axis_s, axis_l) and 1 / inv_minor wide across it.
  struct Footprint {
    double major_m = 0, inv_major = 0, inv_minor = 0;
    bool anisotropic = false;       // major / minor > kAnisoTolerance
    double axis_s = 1, axis_l = 0;  // set only when anisotropic
  };
  /// Footprint of a pixel whose hit moves by (su, lu) / cos_i and (sv, lv) / cos_i in (s, l) per pixel step
  /// along u and v; cos_i: cosine of the incidence angle.
  static Footprint FootprintOf(double cos_i, double su, double lu, double sv, double lv);
  /// Albedo of the intact road at (s, l), each texture octave filtered over the footprint.
  float BaseAlbedo(double s, double l, const Footprint& fp) const;
  template <bool kAniso>
  float FilteredAlbedo(double s, double l, const Footprint& fp) const;
  /// Fraction of the footprint on lane paint (centre dashes, edge lines): the
  /// footprint box's coverage across and along the road, multiplied (exact for
  /// boxes aligned with the road, close for the rotated ones of oblique views).
  double PaintCoverage(double s, double l, const Footprint& fp) const;
  /// Fraction of the sun's disc visible from the road point p, averaged over
  /// the pixel footprint spanned by dp_du and dp_dv (the soft penumbra a pixel
  /// records: width = distance to the occluding edge x tan(0.53 deg)).
  double SunVisibility(const Eigen::Vector3d& p, const Eigen::Vector3d& dp_du, const Eigen::Vector3d& dp_dv) const;
  bool ObstacleHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, double* t, Eigen::Vector3d* n,
                   const Obstacle** which) const;

  void PlaceDamage(const SimulationOptions& o, double s_min, double s_max);
  void PlaceObstacles(const SimulationOptions& o, double s_min, double s_max);

  RoadGeometry road_;
  std::vector<Damage> damages_;
  std::vector<Obstacle> obstacles_;
  Lighting lighting_;
  double sun_gain_ = 1;  // (1 - ambient) / sun z: flat road under the sun gets irradiance 1
  /// Shadow rays per shaded road pixel near an obstacle: each a direction on
  /// the sun's disc paired with a point of the pixel footprint (in units of
  /// dp/du, dp/dv). 16 levels: steps of 1/16 of the shadow contrast.
  static constexpr int kSunSamples = 16;
  /// tan of the sun's angular radius (0.265 deg: its disc is 0.53 deg wide).
  static constexpr double kSunRadiusTan = 4.625e-3;
  std::array<Eigen::Vector3d, kSunSamples> sun_dirs_;
  std::array<Eigen::Vector2d, kSunSamples> sun_offsets_;
  std::unique_ptr<NoiseTable> noise_;
  std::vector<Octave> octaves_;
  std::vector<double> octave_inv_scale_;  // 1 / octaves_[k].scale_m: the texture filter needs no division
  // Damage lookup: grid of kGridCell cells in (s, l); cell c lists damages_
  // indices grid_items_[grid_start_[c] .. grid_start_[c + 1]).
  static constexpr double kGridCell = 0.25;
  double grid_s0_ = 0, grid_l_ = 0;
  int grid_ns_ = 0, grid_nl_ = 0;
  std::vector<int> grid_start_, grid_items_;
  double dash_ = 3.0, gap_ = 5.0;
  bool markings_ = true;
};

}  // namespace rs::sim
