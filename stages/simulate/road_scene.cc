#include "stages/simulate/road_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace rs::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

inline double Clamp01(double x) { return x < 0 ? 0 : (x > 1 ? 1 : x); }
inline double SmoothStep(double a, double b, double x) {
  const double t = Clamp01((x - a) / (b - a));
  return t * t * (3 - 2 * t);
}

/// Bilinear sample of a patch array and its derivatives in cell units.
template <class T>
inline double Bilinear(const std::vector<T>& v, int ns, int i0, int j0, double wi, double wj, double* d_di,
                       double* d_dj) {
  const size_t k = static_cast<size_t>(j0) * ns + i0;
  const double v00 = v[k], v10 = v[k + 1], v01 = v[k + ns], v11 = v[k + ns + 1];
  if (d_di) *d_di = (v10 - v00) * (1 - wj) + (v11 - v01) * wj;
  if (d_dj) *d_dj = (v01 - v00) * (1 - wi) + (v11 - v10) * wi;
  return (v00 * (1 - wi) + v10 * wi) * (1 - wj) + (v01 * (1 - wi) + v11 * wi) * wj;
}

/// atan(k / 8), k = 0..8: the anchors of AtanRel's range reduction.
const std::array<double, 9> kAtanEighths = [] {
  std::array<double, 9> a{};
  for (int k = 0; k <= 8; ++k) a[k] = std::atan(k / 8.0);
  return a;
}();

/// atan2(y, x) for the common case x > 0, |y| <= x (angles within 45 deg), at
/// full double precision for a fraction of libm's cost: atan(a) = atan(k/8) +
/// atan(u), u = (a - k/8) / (1 + a k/8), |u| <= 1/16, and atan(u) by its Taylor
/// series to u^13 (truncation < 1e-19). Other quadrants go to std::atan2.
/// ToRoad runs several times per rendered pixel on curved roads, which made
/// libm's atan2 the renderer's largest single cost.
inline double Atan2Fast(double y, double x) {
  if (!(x > 0) || std::abs(y) > x) return std::atan2(y, x);
  const double z = y / x, a = std::abs(z);
  const int k = static_cast<int>(a * 8.0 + 0.5);
  const double q = k * 0.125;
  const double u = (a - q) / (1.0 + a * q), u2 = u * u;
  const double p =
      u * (1.0 + u2 * (-1.0 / 3 + u2 * (1.0 / 5 + u2 * (-1.0 / 7 + u2 * (1.0 / 9 + u2 * (-1.0 / 11 + u2 * (1.0 / 13)))))));
  const double r = kAtanEighths[k] + p;
  return z < 0 ? -r : r;
}

}  // namespace

const char* ToString(DamageType t) {
  switch (t) {
    case DamageType::kPothole: return "pothole";
    case DamageType::kCrackLongitudinal: return "crack_longitudinal";
    case DamageType::kCrackTransverse: return "crack_transverse";
    case DamageType::kAlligator: return "alligator_cracking";
    case DamageType::kPatch: return "patch";
  }
  return "?";
}

// ---------------------------------------------------------------- RoadGeometry

RoadGeometry::RoadGeometry(const SimulationOptions& o)
    : heading0_((90.0 - o.road_heading_deg) * kDeg),
      curvature_(std::abs(o.road_curvature_1_m) < 1e-9 ? 0.0 : o.road_curvature_1_m),
      grade_(o.road_grade),
      crossfall_(o.road_crossfall),
      half_width_(o.road_width_m / 2),
      kerb_height_(o.kerb_height_m),
      cos0_(std::cos(heading0_)),
      sin0_(std::sin(heading0_)) {
  if (curvature_ != 0) {
    centre_ = Eigen::Vector2d(-std::sin(heading0_), std::cos(heading0_)) / curvature_;
  } else {
    centre_.setZero();
  }
}

Eigen::Vector2d RoadGeometry::ToWorld(double s, double l) const {
  const double h = HeadingRad(s);
  const Eigen::Vector2d n(-std::sin(h), std::cos(h));
  if (curvature_ == 0) return s * Eigen::Vector2d(std::cos(h), std::sin(h)) + l * n;
  return centre_ - (1.0 / curvature_ - l) * n;
}

void RoadGeometry::ToRoad(double x, double y, double* s, double* l, double* cos_h, double* sin_h) const {
  if (curvature_ == 0) {
    const double c = std::cos(heading0_), sn = std::sin(heading0_);
    *s = c * x + sn * y;
    *l = -sn * x + c * y;
    if (cos_h) *cos_h = c, *sin_h = sn;
    return;
  }
  const double vx = x - centre_.x(), vy = y - centre_.y();
  const double r = std::sqrt(vx * vx + vy * vy);
  const double rho = 1.0 / curvature_;
  const double sg = rho > 0 ? 1.0 : -1.0;
  *l = rho - sg * r;
  // n(s) = -v / (sg r) = (-sin h, cos h)
  const double nx = -vx * sg / r, ny = -vy * sg / r;
  if (cos_h) *cos_h = ny, *sin_h = -nx;
  // Heading relative to heading0_, in [-pi, pi]: (cos, sin) of h - heading0_.
  const double c_rel = ny * cos0_ - nx * sin0_, s_rel = -nx * cos0_ - ny * sin0_;
  *s = Atan2Fast(s_rel, c_rel) / curvature_;
}

double RoadGeometry::IntactZ(double s, double l, double* dz_ds, double* dz_dl) const {
  const double a = std::abs(l), sg = l < 0 ? -1.0 : 1.0;
  const double hw = half_width_, kw = kerb_width();
  constexpr double kRamp = 0.01;  // kerb face width: steep but continuous, so normals stay defined
  double zl, dzl;
  if (a <= hw) {
    zl = -crossfall_ * a;
    dzl = -crossfall_;
  } else if (a <= hw + kRamp) {
    zl = -crossfall_ * hw + kerb_height_ * (a - hw) / kRamp;
    dzl = kerb_height_ / kRamp;
  } else if (a <= hw + kw) {
    zl = -crossfall_ * hw + kerb_height_;
    dzl = 0;
  } else {
    zl = -crossfall_ * hw + kerb_height_ + 0.03 * (a - hw - kw);
    dzl = 0.03;
  }
  if (dz_ds) *dz_ds = grade_;
  if (dz_dl) *dz_dl = dzl * sg;
  return grade_ * s + zl;
}

// ---------------------------------------------------------------- RoadScene

RoadScene::RoadScene(const SimulationOptions& o, double s_view_min, double s_view_max)
    : road_(o), noise_(std::make_unique<NoiseTable>(HashCombine(static_cast<uint64_t>(o.seed), 7))) {
  Rng rng(HashCombine(static_cast<uint64_t>(o.seed), 3));
  // Texture octaves: fine grain, aggregate stones, mortar, stains, large-scale tone.
  for (double scale : {0.0035, 0.009, 0.035, 0.3, 4.0}) {
    const double a = rng.Uniform(0, 2 * kPi);
    octaves_.push_back({scale, std::cos(a), std::sin(a), rng.Uniform(0, 1024), rng.Uniform(0, 1024)});
  }
  const double az = o.sun_azimuth_deg * kDeg, el = o.sun_elevation_deg * kDeg;
  lighting_.sun_world = Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el));
  lighting_.shadows = o.shadows;
  markings_ = o.lane_markings;

  PlaceDamage(o, s_view_min, s_view_max);
  PlaceObstacles(o, s_view_min, s_view_max);

  bin_s0_ = std::floor(s_view_min) - 1;
  bins_.assign(static_cast<size_t>(std::ceil(s_view_max - bin_s0_)) + 2, {});
  for (size_t k = 0; k < damages_.size(); ++k) {
    const Damage& d = damages_[k];
    const int b0 = std::max(0, static_cast<int>(std::floor(d.s0 - bin_s0_)));
    const int b1 = std::min(static_cast<int>(bins_.size()) - 1, static_cast<int>(std::floor(d.s_max() - bin_s0_)));
    for (int b = b0; b <= b1; ++b) bins_[b].push_back(static_cast<int>(k));
  }
}

const Damage* RoadScene::DamageAt(double s, double l) const {
  const double fb = s - bin_s0_;
  if (fb < 0 || fb >= static_cast<double>(bins_.size())) return nullptr;
  for (int k : bins_[static_cast<size_t>(fb)]) {
    const Damage& d = damages_[k];
    if (s >= d.s0 && s < d.s_max() && l >= d.l0 && l < d.l_max()) return &d;
  }
  return nullptr;
}

RoadScene::SurfaceSample RoadScene::Surface(double s, double l) const {
  SurfaceSample out;
  out.z = road_.IntactZ(s, l, &out.dz_ds, &out.dz_dl);
  const Damage* d = DamageAt(s, l);
  if (!d) return out;
  out.damage = d;
  out.fi = (s - d->s0) / d->res - 0.5;
  out.fj = (l - d->l0) / d->res - 0.5;
  const int i0 = std::clamp(static_cast<int>(std::floor(out.fi)), 0, d->ns - 2);
  const int j0 = std::clamp(static_cast<int>(std::floor(out.fj)), 0, d->nl - 2);
  const double wi = Clamp01(out.fi - i0), wj = Clamp01(out.fj - j0);
  double ddi, ddj;
  const double def = Bilinear(d->deficit_m, d->ns, i0, j0, wi, wj, &ddi, &ddj);
  out.z -= def;
  out.dz_ds -= ddi / d->res;
  out.dz_dl -= ddj / d->res;
  return out;
}

double RoadScene::HeightAt(double x, double y) const {
  double s, l;
  road_.ToRoad(x, y, &s, &l);
  return Surface(s, l).z;
}

double RoadScene::IntactHeightAt(double x, double y) const {
  double s, l;
  road_.ToRoad(x, y, &s, &l);
  return road_.IntactZ(s, l);
}

int RoadScene::LabelAt(double x, double y) const {
  double s, l;
  road_.ToRoad(x, y, &s, &l);
  const Damage* d = DamageAt(s, l);
  if (!d) return 0;
  const int i = std::clamp(static_cast<int>((s - d->s0) / d->res), 0, d->ns - 1);
  const int j = std::clamp(static_cast<int>((l - d->l0) / d->res), 0, d->nl - 1);
  return d->mask[static_cast<size_t>(j) * d->ns + i] ? d->id : 0;
}

float RoadScene::BaseAlbedo(double s, double l, double fp) const {
  // Octaves finer than ~1.75 px fade to their mean: a cheap, deterministic
  // prefilter, so left and right views of a point agree and nothing aliases.
  auto w = [fp](double scale) { return Clamp01(scale / fp - 0.75); };
  const NoiseTable& t = *noise_;
  const double a = std::abs(l), hw = road_.half_width();
  const double stain = octaves_[3].At(t, s, l) - 0.5;
  const double w0 = w(octaves_[0].scale_m), w1 = w(octaves_[1].scale_m), w2 = w(octaves_[2].scale_m);
  const double fine = w0 > 0 ? w0 * (octaves_[0].At(t, s, l) - 0.5) : 0.0;
  const double mid = w2 > 0 ? w2 * (octaves_[2].At(t, s, l) - 0.5) : 0.0;
  if (a <= hw) {
    const double big = octaves_[4].At(t, s, l) - 0.5;
    constexpr double kStoneMean = 0.227;  // mean of the stone term over the noise table (checked in a test)
    const double stone = w1 > 0 ? SmoothStep(0.58, 0.74, octaves_[1].At(t, s, l)) : 0.0;
    double alb = 0.16 + 0.07 * big + 0.05 * stain + 0.22 * (w1 * stone + (1 - w1) * kStoneMean) + 0.06 * mid +
                 0.12 * fine;
    if (markings_) {
      const bool centre = a < 0.06 && std::fmod(std::abs(s), dash_ + gap_) < dash_;
      const bool edge = std::abs(a - (hw - 0.3)) < 0.075;
      if (centre || edge) alb = 0.40 + 0.08 * stain + 0.08 * fine + 0.04 * mid;
    }
    return static_cast<float>(alb);
  }
  if (a <= hw + road_.kerb_width()) return static_cast<float>(0.42 + 0.05 * stain + 0.08 * mid + 0.10 * fine);
  const double blades = w1 > 0 ? w1 * (octaves_[1].At(t, s, l) - 0.5) : 0.0;
  return static_cast<float>(0.12 + 0.05 * stain + 0.10 * mid + 0.12 * blades + 0.06 * fine);
}

bool RoadScene::ObstacleHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, double* t_out,
                            Eigen::Vector3d* n_out, const Obstacle** which) const {
  bool any = false;
  double best = t_max;
  for (const Obstacle& ob : obstacles_) {
    {
      // Bounding-sphere rejection: most rays pass far from every obstacle, and
      // this costs a few multiplies instead of a rotated slab or quadric test.
      const bool box = ob.kind == Obstacle::Kind::kBox;
      const double hz = box ? 0.0 : 0.5 * ob.half_size.z();
      const Eigen::Vector3d w = ob.centre + Eigen::Vector3d(0, 0, hz) - o;
      const double r2 = box ? ob.half_size.squaredNorm() : ob.half_size.x() * ob.half_size.x() + hz * hz;
      const double tc = w.dot(d);
      const double dist2 = w.squaredNorm() - tc * tc;
      if (dist2 > r2 * 1.0001 + 1e-9) continue;
      const double r = std::sqrt(r2) * 1.0001 + 1e-6;
      if (tc + r < 0 || tc - r > best) continue;
    }
    if (ob.kind == Obstacle::Kind::kBox) {
      const Eigen::Vector3d ol = ob.R_world_obj.transpose() * (o - ob.centre);
      const Eigen::Vector3d dl = ob.R_world_obj.transpose() * d;
      double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
      int axis = -1;
      double sign = 0;
      bool miss = false;
      for (int k = 0; k < 3 && !miss; ++k) {
        if (std::abs(dl[k]) < 1e-12) {
          if (std::abs(ol[k]) > ob.half_size[k]) miss = true;
          continue;
        }
        double ta = (-ob.half_size[k] - ol[k]) / dl[k], tb = (ob.half_size[k] - ol[k]) / dl[k];
        double sg = -1;
        if (ta > tb) {
          std::swap(ta, tb);
          sg = 1;
        }
        if (ta > t0) {
          t0 = ta;
          axis = k;
          sign = sg;
        }
        t1 = std::min(t1, tb);
        if (t0 > t1) miss = true;
      }
      if (!miss && axis >= 0 && t0 > 1e-6 && t0 < best) {
        best = t0;
        Eigen::Vector3d nl = Eigen::Vector3d::Zero();
        nl[axis] = sign;
        *n_out = ob.R_world_obj * nl;
        *which = &ob;
        any = true;
      }
    } else {
      const double r = ob.half_size.x(), h = ob.half_size.z();
      const double px = o.x() - ob.centre.x(), py = o.y() - ob.centre.y();
      const double A = d.x() * d.x() + d.y() * d.y();
      const double B = 2 * (px * d.x() + py * d.y());
      const double C = px * px + py * py - r * r;
      const double disc = B * B - 4 * A * C;
      if (A > 1e-12 && disc >= 0) {
        const double t = (-B - std::sqrt(disc)) / (2 * A);
        const double z = o.z() + t * d.z() - ob.centre.z();
        if (t > 1e-6 && t < best && z >= 0 && z <= h) {
          best = t;
          *n_out = Eigen::Vector3d(px + t * d.x(), py + t * d.y(), 0).normalized();
          *which = &ob;
          any = true;
        }
      }
      if (std::abs(d.z()) > 1e-12) {  // top cap
        const double t = (ob.centre.z() + h - o.z()) / d.z();
        const double qx = px + t * d.x(), qy = py + t * d.y();
        if (t > 1e-6 && t < best && qx * qx + qy * qy <= r * r) {
          best = t;
          *n_out = Eigen::Vector3d::UnitZ();
          *which = &ob;
          any = true;
        }
      }
    }
  }
  if (any) *t_out = best;
  return any;
}

RayHit RoadScene::Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double pixel_angle_rad,
                       double z_start) const {
  RayHit out;
  constexpr double kMaxRange = 300.0;
  double t_obs = kMaxRange;
  Eigen::Vector3d n_obs;
  const Obstacle* obs = nullptr;
  const bool hit_obs = !obstacles_.empty() && ObstacleHit(o, d, kMaxRange, &t_obs, &n_obs, &obs);

  // Road surface: Newton on f(t) = ray z - surface z, started on the smooth road
  // under the ray origin; a bracketing march handles kerb faces and pothole walls.
  bool hit_surf = false;
  double t = 0, s = 0, l = 0;
  double ch = 1, sh = 0;  // centreline direction at s: from ToRoad, so shading needs no cos/sin of the heading
  SurfaceSample S;
  if (d.z() < -1e-4) {
    if (std::isnan(z_start)) {
      road_.ToRoad(o.x(), o.y(), &s, &l);
      z_start = road_.SmoothZ(s, l);
    }
    t = (z_start - o.z()) / d.z();
    bool converged = false;
    for (int it = 0; it < 8 && t > 0 && t < kMaxRange; ++it) {
      const Eigen::Vector3d p = o + t * d;
      road_.ToRoad(p.x(), p.y(), &s, &l, &ch, &sh);
      S = Surface(s, l);
      const double f = p.z() - S.z;
      if (std::abs(f) < 1e-5) {
        converged = true;
        break;
      }
      const double gs = S.dz_ds / road_.Stretch(l);
      const double gx = gs * ch - S.dz_dl * sh, gy = gs * sh + S.dz_dl * ch;
      const double fp = d.z() - (gx * d.x() + gy * d.y());
      if (fp > -1e-3) break;  // surface as steep as the ray: Newton unreliable here
      t -= f / fp;
    }
    if (!converged) {
      // March down from above the highest possible surface, then bisect.
      double ts = (road_.SmoothZ(s, l) - o.z()) / d.z();
      for (int it = 0; it < 4; ++it) {
        const Eigen::Vector3d p = o + ts * d;
        road_.ToRoad(p.x(), p.y(), &s, &l);
        ts = (road_.SmoothZ(s, l) - o.z()) / d.z();
      }
      const double dzt = -d.z();
      double ta = std::max(0.0, ts - 0.5 / dzt), tb_limit = ts + 0.5 / dzt;
      auto F = [&](double tt) {
        const Eigen::Vector3d p = o + tt * d;
        road_.ToRoad(p.x(), p.y(), &s, &l, &ch, &sh);
        S = Surface(s, l);
        return p.z() - S.z;
      };
      double fa = F(ta);
      const double slope_bound = dzt + std::sqrt(d.x() * d.x() + d.y() * d.y());
      for (int it = 0; it < 2000 && ta < tb_limit && ta < kMaxRange; ++it) {
        const double tb = ta + std::max(fa, 0.002) / slope_bound;
        const double fb = F(tb);
        if (fb <= 0) {
          double lo = ta, hi = tb;
          for (int k = 0; k < 30; ++k) {
            const double mid = 0.5 * (lo + hi);
            (F(mid) > 0 ? lo : hi) = mid;
          }
          t = hi;
          F(t);
          converged = true;
          break;
        }
        ta = tb;
        fa = fb;
      }
    }
    hit_surf = converged && t > 0 && t < kMaxRange;
  }

  const Lighting& L = lighting_;
  if (hit_obs && (!hit_surf || t_obs < t)) {
    out.hit = true;
    out.t = t_obs;
    out.p_world = o + t_obs * d;
    const Eigen::Vector3d& p = out.p_world;
    const double tex = octaves_[2].At(*noise_, p.x() + 0.7 * p.z(), p.y() - 0.5 * p.z());
    const double alb = obs->albedo * (0.8 + 0.4 * tex);
    const double irr = L.ambient + (1 - L.ambient) * std::max(0.0, n_obs.dot(L.sun_world)) / L.sun_world.z();
    out.radiance = static_cast<float>(L.exposure * alb * irr);
    return out;
  }
  if (!hit_surf) return out;

  out.hit = true;
  out.t = t;
  out.p_world = o + t * d;
  const double gs = S.dz_ds / road_.Stretch(l);
  const Eigen::Vector3d n =
      Eigen::Vector3d(-(gs * ch - S.dz_dl * sh), -(gs * sh + S.dz_dl * ch), 1.0).normalized();
  const double footprint = t * pixel_angle_rad / std::max(0.2, -n.dot(d));
  double alb = BaseAlbedo(s, l, footprint);
  if (S.damage) {
    const Damage& dm = *S.damage;
    const int i0 = std::clamp(static_cast<int>(std::floor(S.fi)), 0, dm.ns - 2);
    const int j0 = std::clamp(static_cast<int>(std::floor(S.fj)), 0, dm.nl - 2);
    alb *= Bilinear(dm.albedo_mul, dm.ns, i0, j0, Clamp01(S.fi - i0), Clamp01(S.fj - j0), nullptr, nullptr);
    const int i = std::clamp(static_cast<int>(std::lround(S.fi)), 0, dm.ns - 1);
    const int j = std::clamp(static_cast<int>(std::lround(S.fj)), 0, dm.nl - 1);
    if (dm.mask[static_cast<size_t>(j) * dm.ns + i]) out.label = static_cast<uint16_t>(dm.id);
  }
  double irr = L.ambient + (1 - L.ambient) * std::max(0.0, n.dot(L.sun_world)) / L.sun_world.z();
  if (L.shadows && !obstacles_.empty()) {
    double ts;
    Eigen::Vector3d ns;
    const Obstacle* w;
    if (ObstacleHit(out.p_world + 1e-3 * n, L.sun_world, 100.0, &ts, &ns, &w)) irr = L.ambient;
  }
  out.radiance = static_cast<float>(L.exposure * alb * irr);
  return out;
}

}  // namespace rs::sim
