#include "sim/road_scene.h"

#include "sim/footprint_coverage.h"

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
  const double t = Clamp01((x - a) * (1.0 / (b - a)));  // constant a, b: folds to one multiply
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

/// atan(k / 8), k = 0..8: the anchors of Atan2Fast's range reduction.
const std::array<double, 9> kAtanEighths = [] {
  std::array<double, 9> a{};
  for (int k = 0; k <= 8; ++k) a[k] = std::atan(k / 8.0);
  return a;
}();

/// atan2(y, x) for the common case x > 0, |y| <= x (angles within 45 deg), at
/// full double precision for a fraction of libm's cost: atan(a) = atan(k/8) +
/// atan(u), a = |y| / x, u = (|y| - x k/8) / (x + |y| k/8), |u| <= 1/16, and
/// atan(u) by its Taylor series to u^11 (truncation < 2e-17 rad), evaluated in
/// Estrin's form (short dependency chain). k = round(8 a) is found by
/// comparisons, so the only division is the one in u. Other quadrants go to
/// std::atan2. ToRoad runs at least once per rendered pixel on curved roads, and
/// its chain of sqrt and divisions was the renderer's largest cost.
inline double Atan2Fast(double y, double x) {
  const double ay = std::abs(y);
  if (!(x > 0) || ay > x) return std::atan2(y, x);
  const double y8 = 8.0 * ay;
  int k = 0;
  for (int j = 0; j < 8; ++j) k += y8 > (j + 0.5) * x ? 1 : 0;
  const double q = k * 0.125;
  const double u = (ay - q * x) / (x + q * ay), u2 = u * u, u4 = u2 * u2;
  const double p = u * ((1.0 - u2 * (1.0 / 3)) + u4 * ((1.0 / 5 - u2 * (1.0 / 7)) + u4 * (1.0 / 9 - u2 * (1.0 / 11))));
  const double r = kAtanEighths[k] + p;
  return y < 0 ? -r : r;
}

// An obstacle's bounding sphere: a box about its centre, a cylinder about its axis' middle.
void BoundingSphere(const Obstacle& ob, Eigen::Vector3d* centre, double* r2) {
  const bool box = ob.kind == Obstacle::Kind::kBox;
  const double hz = box ? 0.0 : 0.5 * ob.half_size.z();
  *centre = ob.centre + Eigen::Vector3d(0, 0, hz);
  *r2 = box ? ob.half_size.squaredNorm() : ob.half_size.x() * ob.half_size.x() + hz * hz;
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
      sin0_(std::sin(heading0_)),
      rho_(curvature_ != 0 ? 1.0 / curvature_ : 0.0) {
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
    *s = cos0_ * x + sin0_ * y;
    *l = -sin0_ * x + cos0_ * y;
    if (cos_h) *cos_h = cos0_, *sin_h = sin0_;
    return;
  }
  const double vx = x - centre_.x(), vy = y - centre_.y();
  const double r = std::sqrt(vx * vx + vy * vy);
  const double m = rho_ > 0 ? -1.0 : 1.0;
  *l = rho_ + m * r;
  // n(s) = m v / r = (-sin h, cos h). The heading relative to heading0_ is the
  // angle of (cos, sin) of h - heading0_, here scaled by r: atan2 needs no 1/r.
  const double c_rel = m * (vy * cos0_ - vx * sin0_), s_rel = m * (-vx * cos0_ - vy * sin0_);
  *s = Atan2Fast(s_rel, c_rel) * rho_;
  if (cos_h) {
    const double k = m / r;
    *cos_h = vy * k;
    *sin_h = -vx * k;
  }
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
    octave_inv_scale_.push_back(1.0 / scale);
  }
  const double az = o.sun_azimuth_deg * kDeg, el = o.sun_elevation_deg * kDeg;
  lighting_.sun_world = Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el));
  lighting_.shadows = o.shadows;
  sun_gain_ = (1 - lighting_.ambient) / lighting_.sun_world.z();
  markings_ = o.lane_markings;
  // Shadow samples: directions spread evenly over the sun's disc (a Vogel
  // spiral), each paired with a footprint point of a 4 x 4 grid in scrambled
  // order so that neither set lines up with the other.
  {
    const Eigen::Vector3d& sun = lighting_.sun_world;
    const Eigen::Vector3d e1 = sun.unitOrthogonal(), e2 = sun.cross(e1);
    const double golden = kPi * (3 - std::sqrt(5.0));
    for (int k = 0; k < kSunSamples; ++k) {
      const double r = kSunRadiusTan * std::sqrt((k + 0.5) / kSunSamples), a = k * golden;
      sun_dirs_[k] = (sun + r * (std::cos(a) * e1 + std::sin(a) * e2)).normalized();
      const int m = (k * 7) % kSunSamples;
      sun_offsets_[k] = Eigen::Vector2d((m % 4 + 0.5) / 4 - 0.5, (m / 4 + 0.5) / 4 - 0.5);
    }
  }

  PlaceDamage(o, s_view_min, s_view_max);
  PlaceObstacles(o, s_view_min, s_view_max);

  // Damage lookup grid over [grid_s0_, s_view_max + 3] x [-grid_l_, grid_l_]: each cell lists the damages
  // whose patch overlaps it, so most surface samples test no damage at all.
  grid_s0_ = std::floor(s_view_min) - 1;
  grid_l_ = kGridCell;
  for (const Damage& d : damages_)
    grid_l_ = std::max({grid_l_, std::abs(d.l0) + kGridCell, std::abs(d.l_max()) + kGridCell});
  grid_ns_ = static_cast<int>(std::ceil((s_view_max + 3 - grid_s0_) / kGridCell));
  grid_nl_ = static_cast<int>(std::ceil(2 * grid_l_ / kGridCell));
  std::vector<std::vector<int>> cells(static_cast<size_t>(grid_ns_) * grid_nl_);
  auto cell_of = [](double x, int n) { return std::clamp(static_cast<int>(std::floor(x / kGridCell)), 0, n - 1); };
  for (size_t k = 0; k < damages_.size(); ++k) {
    const Damage& d = damages_[k];
    if (d.s_max() < grid_s0_ || d.s0 >= grid_s0_ + grid_ns_ * kGridCell) continue;
    const int i0 = cell_of(d.s0 - grid_s0_, grid_ns_), i1 = cell_of(d.s_max() - grid_s0_, grid_ns_);
    const int j0 = cell_of(d.l0 + grid_l_, grid_nl_), j1 = cell_of(d.l_max() + grid_l_, grid_nl_);
    for (int i = i0; i <= i1; ++i)
      for (int j = j0; j <= j1; ++j) cells[static_cast<size_t>(i) * grid_nl_ + j].push_back(static_cast<int>(k));
  }
  grid_start_.assign(cells.size() + 1, 0);
  for (size_t c = 0; c < cells.size(); ++c) {
    grid_start_[c + 1] = grid_start_[c] + static_cast<int>(cells[c].size());
    grid_items_.insert(grid_items_.end(), cells[c].begin(), cells[c].end());
  }
}

const Damage* RoadScene::DamageAt(double s, double l) const {
  const double fs = (s - grid_s0_) * (1.0 / kGridCell), fl = (l + grid_l_) * (1.0 / kGridCell);
  if (!(fs >= 0 && fs < grid_ns_ && fl >= 0 && fl < grid_nl_)) return nullptr;
  const size_t c = static_cast<size_t>(fs) * grid_nl_ + static_cast<size_t>(fl);
  for (int q = grid_start_[c]; q < grid_start_[c + 1]; ++q) {
    const Damage& d = damages_[grid_items_[q]];
    if (s >= d.s0 && s < d.s_max() && l >= d.l0 && l < d.l_max()) return &d;
  }
  return nullptr;
}

RoadScene::SurfaceSample RoadScene::Surface(double s, double l) const {
  SurfaceSample out;
  out.z = out.intact_z = road_.IntactZ(s, l, &out.dz_ds, &out.dz_dl);
  out.intact_dz_ds = out.dz_ds;
  out.intact_dz_dl = out.dz_dl;
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

PixelDifferentials PixelDifferentials::Square(const Eigen::Vector3d& d, double pixel_angle_rad) {
  Eigen::Vector3d right = d.cross(Eigen::Vector3d::UnitZ());
  const double n = right.norm();
  right = n > 1e-9 ? Eigen::Vector3d(right / n) : Eigen::Vector3d::UnitX().cross(d).cross(d).normalized();
  PixelDifferentials px;
  px.dd_du = pixel_angle_rad * right;
  px.dd_dv = pixel_angle_rad * d.cross(right);
  return px;
}

RoadScene::Footprint RoadScene::FootprintOf(double cos_i, double su, double lu, double sv, double lv) {
  // The pixel maps to the parallelogram J [-1/2, 1/2]^2, J = [su sv; lu lv] / cos_i. As texture hardware
  // does, its long axis is the longer column (from a forward camera: the image's vertical direction on the
  // road) and its width across that axis |det J| / long side (exact for the parallelogram). All of it from
  // one square root and one division, independent of each other: the renderer's per-pixel time is mostly
  // such latency chains.
  const double ru = su * su + lu * lu, rv = sv * sv + lv * lv;
  const bool v_long = rv >= ru;
  const double l2 = v_long ? rv : ru;  // (cos_i * long side)^2
  // Guard: a footprint seen exactly edge-on has no width.
  const double det = std::max(std::abs(su * lv - sv * lu), 1e-6 * l2 + 1e-30);  // cos_i^2 |det J|
  const double lc = std::sqrt(l2);
  const double q = 1.0 / (l2 * det * cos_i);
  const double inv_lc = lc * det * cos_i * q, cc = cos_i * cos_i;
  Footprint fp;
  fp.major_m = lc * det * l2 * q;  // lc / cos_i
  fp.inv_major = cos_i * inv_lc;
  fp.inv_minor = cc * l2 * lc * q;              // cos_i lc / det
  fp.anisotropic = l2 > kAnisoTolerance * det;  // major / minor = l2 / det
  if (fp.anisotropic) {
    fp.axis_s = (v_long ? sv : su) * inv_lc;
    fp.axis_l = (v_long ? lv : lu) * inv_lc;
  }
  return fp;
}

float RoadScene::BaseAlbedo(double s, double l, const Footprint& fp) const {
  // Most pixels of nadir views are isotropic: one sample per octave, compiled without the sampling loop.
  return fp.anisotropic ? FilteredAlbedo<true>(s, l, fp) : FilteredAlbedo<false>(s, l, fp);
}

template <bool kAniso>
float RoadScene::FilteredAlbedo(double s, double l, const Footprint& fp) const {
  // A pixel records the mean radiance over its footprint, a box long along the
  // view and narrow across it at grazing angles. Per octave, n point samples
  // spread along the long axis, each standing for a box of major / n by minor,
  // and the octave fades by that box's longer side as the isotropic prefilter
  // did: full contrast for texels of >= 1.75 box sides, none below 1.33 (a
  // cheap, deterministic stand-in for mip levels; nothing aliases, and left and
  // right views of a point agree as their footprints do). Samples are only
  // taken as densely as the octave needs (spacing max(minor, texel / 1.75)),
  // so coarse octaves stay at one sample.
  const NoiseTable& t = *noise_;
  // Mean of f(octave value) over the octave's samples; *w: the contrast kept.
  auto filtered = [&](int octave, double* w, auto&& f) -> double {
    const Octave& oc = octaves_[octave];
    int n = 1;
    double inv_box = fp.inv_major;  // 1 / the longer side of the box one sample stands for
    if constexpr (kAniso) {
      // Samples needed: major / spacing, spacing = max(minor, texel / 1.75) (closer adds nothing).
      const double need = fp.major_m * std::min(fp.inv_minor, 1.75 * octave_inv_scale_[octave]);
      if (need > kAnisoTolerance) {
        n = static_cast<int>(std::min<double>(kMaxAnisotropy, std::ceil(need - (kAnisoTolerance - 1))));
        inv_box = std::min(fp.inv_minor, n * fp.inv_major);
      }
    }
    *w = Clamp01(oc.scale_m * inv_box - 0.75);
    if (*w == 0) return 0.0;
    if (!kAniso || n == 1) return f(oc.At(t, s, l));
    // Texel coordinates step linearly along the axis (Octave::At is affine in (s, l)).
    const double inv_n = 1.0 / n, step = fp.major_m * inv_n;
    const double dx = step * (oc.cu * fp.axis_s - oc.su * fp.axis_l);
    const double dy = step * (oc.su * fp.axis_s + oc.cu * fp.axis_l);
    const double k0 = 0.5 - 0.5 * n;  // x0 / step
    double tx = oc.cu * s - oc.su * l + oc.ox + k0 * dx, ty = oc.su * s + oc.cu * l + oc.oy + k0 * dy;
    double sum = 0;
    for (int k = 0; k < n; ++k, tx += dx, ty += dy) sum += f(t.Sample(tx, ty));
    return sum * inv_n;
  };
  // Octave k about its mean 0.5, filtered.
  auto centred = [&](int k) {
    double w;
    const double mean = filtered(k, &w, [](double v) { return v - 0.5; });
    return w * mean;
  };
  const double a = std::abs(l), hw = road_.half_width();
  const double stain = centred(3), fine = centred(0), mid = centred(2);
  if (a <= hw) {
    const double big = centred(4);
    constexpr double kStoneMean = 0.227;  // mean of the stone term over the noise table (checked in a test)
    double w;
    const double stones = filtered(1, &w, [](double v) { return SmoothStep(0.58, 0.74, v); });
    const double stone = w * stones + (1 - w) * kStoneMean;
    double alb = 0.16 + 0.07 * big + 0.05 * stain + 0.22 * stone + 0.06 * mid + 0.12 * fine;
    if (markings_) {
      const double paint = PaintCoverage(s, l, fp);
      if (paint > 0) alb += paint * (0.40 + 0.08 * stain + 0.08 * fine + 0.04 * mid - alb);
    }
    return static_cast<float>(alb);
  }
  if (a <= hw + road_.kerb_width()) return static_cast<float>(0.42 + 0.05 * stain + 0.08 * mid + 0.10 * fine);
  const double blades = centred(1);
  return static_cast<float>(0.12 + 0.05 * stain + 0.10 * mid + 0.12 * blades + 0.06 * fine);
}

double RoadScene::PaintCoverage(double s, double l, const Footprint& fp) const {
  // The footprint box (major along the axis, minor across it) projects on the
  // l axis as sides major |axis_l| and minor |axis_s|, on the s axis the other
  // way round; isotropic footprints keep axis (1, 0).
  const double minor = 1.0 / fp.inv_minor;
  const double al = fp.major_m * std::abs(fp.axis_l), bl = minor * std::abs(fp.axis_s);
  const double hw = road_.half_width();
  // Edge lines: 0.15 m wide, centred 0.3 m inside the road edges.
  double paint = StripCoverage(l, hw - 0.375, hw - 0.225, al, bl) + StripCoverage(l, 0.225 - hw, 0.375 - hw, al, bl);
  // Centre line: 0.12 m wide, dashes [k P, k P + dash] in |s| (P = dash + gap).
  const double across = StripCoverage(l, -0.06, 0.06, al, bl);
  if (across > 0) {
    const double as = fp.major_m * std::abs(fp.axis_s), bs = minor * std::abs(fp.axis_l);
    const double period = dash_ + gap_, sa = std::abs(s);
    const double k = std::floor(sa / period);
    double along = 0;
    for (double j = k - 1; j <= k + 1; ++j) along += StripCoverage(sa, j * period, j * period + dash_, as, bs);
    paint += across * along;
  }
  return std::min(paint, 1.0);
}

double RoadScene::SunVisibility(const Eigen::Vector3d& p, const Eigen::Vector3d& dp_du,
                                const Eigen::Vector3d& dp_dv) const {
  // Most road pixels are nowhere near an obstacle's shadow: one test of the
  // central sun ray against each bounding sphere, grown by how far the
  // samples can stray from that ray (footprint radius + distance x sun radius).
  const Eigen::Vector3d& sun = lighting_.sun_world;
  const double foot_r = 0.5 * (dp_du.norm() + dp_dv.norm());
  bool near = false;
  for (const Obstacle& ob : obstacles_) {
    Eigen::Vector3d c;
    double r2;
    BoundingSphere(ob, &c, &r2);
    const Eigen::Vector3d w = c - p;
    const double tc = w.dot(sun);
    const double r = std::sqrt(r2) + foot_r + std::max(tc, 0.0) * kSunRadiusTan * 1.01 + 1e-4;
    if (tc + r < 0) continue;
    if (w.squaredNorm() - tc * tc <= r * r) {
      near = true;
      break;
    }
  }
  if (!near) return 1.0;
  int lit = 0;
  double t;
  Eigen::Vector3d n;
  const Obstacle* which;
  for (int k = 0; k < kSunSamples; ++k) {
    const Eigen::Vector3d o = p + sun_offsets_[k].x() * dp_du + sun_offsets_[k].y() * dp_dv;
    if (!ObstacleHit(o, sun_dirs_[k], 100.0, &t, &n, &which)) ++lit;
  }
  return lit * (1.0 / kSunSamples);
}

bool RoadScene::ObstacleHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max, double* t_out,
                            Eigen::Vector3d* n_out, const Obstacle** which) const {
  bool any = false;
  double best = t_max;
  for (const Obstacle& ob : obstacles_) {
    {
      // Bounding-sphere rejection: most rays pass far from every obstacle, and
      // this costs a few multiplies instead of a rotated slab or quadric test.
      Eigen::Vector3d c;
      double r2;
      BoundingSphere(ob, &c, &r2);
      const Eigen::Vector3d w = c - o;
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

bool RoadScene::MarchToSurface(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range, double* t,
                               double* s, double* l, double* ch, double* sh, SurfaceSample* S) const {
  // March down from above the highest possible surface near (s, l), then bisect.
  double ts = (road_.SmoothZ(*s, *l) - o.z()) / d.z();
  for (int it = 0; it < 4; ++it) {
    const Eigen::Vector3d p = o + ts * d;
    road_.ToRoad(p.x(), p.y(), s, l);
    ts = (road_.SmoothZ(*s, *l) - o.z()) / d.z();
  }
  const double dzt = -d.z();
  double ta = std::max(0.0, ts - 0.5 / dzt);
  const double tb_limit = ts + 0.5 / dzt;
  auto F = [&](double tt) {
    const Eigen::Vector3d p = o + tt * d;
    road_.ToRoad(p.x(), p.y(), s, l, ch, sh);
    *S = Surface(*s, *l);
    return p.z() - S->z;
  };
  double fa = F(ta);
  const double slope_bound = dzt + std::sqrt(d.x() * d.x() + d.y() * d.y());
  for (int it = 0; it < 2000 && ta < tb_limit && ta < max_range; ++it) {
    const double tb = ta + std::max(fa, 0.002) / slope_bound;
    const double fb = F(tb);
    if (fb <= 0) {
      double lo = ta, hi = tb;
      for (int k = 0; k < 30; ++k) {
        const double mid = 0.5 * (lo + hi);
        (F(mid) > 0 ? lo : hi) = mid;
      }
      *t = hi;
      F(hi);
      return true;
    }
    ta = tb;
    fa = fb;
  }
  return false;
}

double RayHit::StartOnPlane(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  if (!road) return std::numeric_limits<double>::quiet_NaN();
  const double den = d.z() - (intact_grad.x() * d.x() + intact_grad.y() * d.y());
  if (den > -1e-4) return std::numeric_limits<double>::quiet_NaN();
  const double num =
      intact_z + intact_grad.x() * (o.x() - p_world.x()) + intact_grad.y() * (o.y() - p_world.y()) - o.z();
  const double t = num / den;
  return t > 0 ? t : std::numeric_limits<double>::quiet_NaN();
}

RayHit RoadScene::Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const PixelDifferentials& pixel,
                       double z_start, double t_guess) const {
  RayHit out;
  constexpr double kMaxRange = 300.0;
  double t_obs = kMaxRange;
  Eigen::Vector3d n_obs;
  const Obstacle* obs = nullptr;
  const bool hit_obs = !obstacles_.empty() && ObstacleHit(o, d, kMaxRange, &t_obs, &n_obs, &obs);

  // Road surface: Newton on f(t) = ray z - surface z, started on a neighbour's
  // tangent plane or the smooth road under the ray origin; a bracketing march
  // handles kerb faces and pothole walls.
  bool hit_surf = false;
  double t = 0, s = 0, l = 0;
  double ch = 1, sh = 0;  // centreline direction at s: from ToRoad, so shading needs no cos/sin of the heading
  SurfaceSample S;
  // Newton from t0. With from_guess, a start below the surface is refused: the
  // first crossing would lie behind it.
  int newton_evals = 0;
  auto newton = [&](double t0, bool from_guess) {
    t = t0;
    newton_evals = 0;
    for (int it = 0; it < 8 && t > 0 && t < kMaxRange; ++it) {
      const Eigen::Vector3d p = o + t * d;
      road_.ToRoad(p.x(), p.y(), &s, &l, &ch, &sh);
      S = Surface(s, l);
      ++newton_evals;
      const double f = p.z() - S.z;
      if (std::abs(f) < 1e-5) return true;
      if (from_guess && it == 0 && f < 0) return false;
      const double gs = S.dz_ds / road_.Stretch(l);
      const double gx = gs * ch - S.dz_dl * sh, gy = gs * sh + S.dz_dl * ch;
      const double fp = d.z() - (gx * d.x() + gy * d.y());
      if (fp > -1e-3) return false;  // surface as steep as the ray: Newton unreliable here
      t -= f / fp;
    }
    return false;
  };
  if (d.z() < -1e-4) {
    // A neighbour's tangent plane lands within micrometres of intact road: one
    // evaluation instead of ~3. Where Newton had to move off that plane into
    // damage, the ray may cross the surface more than once: the search from the
    // road under the origin runs as well and the nearer crossing wins.
    bool converged = t_guess > 0 && t_guess < kMaxRange && newton(t_guess, true);
    if (!converged || (S.damage && newton_evals > 1)) {
      const bool have_guess = converged;
      const double t_g = t, s_g = s, l_g = l, ch_g = ch, sh_g = sh;
      const SurfaceSample S_g = S;
      auto keep_nearer_guess = [&] {
        if (have_guess && (!converged || t_g < t)) {
          t = t_g, s = s_g, l = l_g, ch = ch_g, sh = sh_g, S = S_g;
          converged = true;
        }
      };
      if (std::isnan(z_start)) {
        road_.ToRoad(o.x(), o.y(), &s, &l);
        z_start = road_.SmoothZ(s, l);
      }
      converged = newton((z_start - o.z()) / d.z(), false);
      if (!converged) converged = MarchToSurface(o, d, kMaxRange, &t, &s, &l, &ch, &sh, &S);
      keep_nearer_guess();
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
    const double irr = L.ambient + sun_gain_ * std::max(0.0, n_obs.dot(L.sun_world));
    out.radiance = static_cast<float>(L.exposure * alb * irr);
    return out;
  }
  if (!hit_surf) return out;

  out.hit = true;
  out.t = t;
  out.p_world = o + t * d;
  // Per-pixel shading: one division or square root per quantity, no more (they dominate the latency).
  const double inv_stretch = 1.0 / road_.Stretch(l);
  out.road = true;
  out.intact_z = S.intact_z;
  const double gis = S.intact_dz_ds * inv_stretch;
  out.intact_grad = Eigen::Vector2d(gis * ch - S.intact_dz_dl * sh, gis * sh + S.intact_dz_dl * ch);
  const double gs = S.dz_ds * inv_stretch;
  const Eigen::Vector3d n_raw(-(gs * ch - S.dz_dl * sh), -(gs * sh + S.dz_dl * ch), 1.0);
  const Eigen::Vector3d n = n_raw * (1.0 / std::sqrt(n_raw.squaredNorm()));
  // Footprint on the tangent plane from the ray differentials, dp/du = t (dd/du - d (n.dd/du) / (n.d)), here
  // times cos_i = -n.d (FootprintOf divides once for all).
  const double cos_i = std::max(1e-3, -n.dot(d));
  const Eigen::Vector3d pu = t * (cos_i * pixel.dd_du + n.dot(pixel.dd_du) * d);
  const Eigen::Vector3d pv = t * (cos_i * pixel.dd_dv + n.dot(pixel.dd_dv) * d);
  const Footprint fp = FootprintOf(cos_i, (pu.x() * ch + pu.y() * sh) * inv_stretch, pu.y() * ch - pu.x() * sh,
                                   (pv.x() * ch + pv.y() * sh) * inv_stretch, pv.y() * ch - pv.x() * sh);
  double alb = BaseAlbedo(s, l, fp);
  if (S.damage) {
    const Damage& dm = *S.damage;
    const int i0 = std::clamp(static_cast<int>(std::floor(S.fi)), 0, dm.ns - 2);
    const int j0 = std::clamp(static_cast<int>(std::floor(S.fj)), 0, dm.nl - 2);
    alb *= Bilinear(dm.albedo_mul, dm.ns, i0, j0, Clamp01(S.fi - i0), Clamp01(S.fj - j0), nullptr, nullptr);
    // Nearest cell (floor(x + 0.5): no libm lround call per pixel; halves only differ below 0, clamped anyway).
    const int i = std::clamp(static_cast<int>(std::floor(S.fi + 0.5)), 0, dm.ns - 1);
    const int j = std::clamp(static_cast<int>(std::floor(S.fj + 0.5)), 0, dm.nl - 1);
    if (dm.mask[static_cast<size_t>(j) * dm.ns + i]) out.label = static_cast<uint16_t>(dm.id);
  }
  double irr = L.ambient + sun_gain_ * std::max(0.0, n.dot(L.sun_world));
  if (L.shadows && !obstacles_.empty()) {
    // The sun's share of the irradiance, scaled by the visible part of its disc.
    const double inv_cos = 1.0 / cos_i;
    irr = L.ambient + (irr - L.ambient) * SunVisibility(out.p_world + 1e-3 * n, pu * inv_cos, pv * inv_cos);
  }
  out.radiance = static_cast<float>(L.exposure * alb * irr);
  return out;
}

}  // namespace rs::sim
