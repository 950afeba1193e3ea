// Random damage and obstacle placement for RoadScene: shapes, fine heightfield
// patches and their true measurements.
#include <algorithm>
#include <cmath>

#include "sim/road_scene.h"
#include "sim/truth_grading.h"

namespace rs::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

inline double Clamp01(double x) { return x < 0 ? 0 : (x > 1 ? 1 : x); }
inline double SmoothStep(double a, double b, double x) {
  const double t = Clamp01((x - a) / (b - a));
  return t * t * (3 - 2 * t);
}

struct Box {
  double s0, s1, l0, l1;
  bool Overlaps(const Box& o, double gap) const {
    return s0 < o.s1 + gap && o.s0 < s1 + gap && l0 < o.l1 + gap && o.l0 < l1 + gap;
  }
};

/// Allocates the patch grid covering [s0, s1] x [l0, l1] plus a zero border.
void AllocatePatch(Damage* d, double s0, double s1, double l0, double l1, double res) {
  d->res = res;
  d->s0 = s0 - 3 * res;
  d->l0 = l0 - 3 * res;
  d->ns = static_cast<int>(std::ceil((s1 - s0) / res)) + 6;
  d->nl = static_cast<int>(std::ceil((l1 - l0) / res)) + 6;
  const size_t n = static_cast<size_t>(d->ns) * d->nl;
  d->deficit_m.assign(n, 0.0f);
  d->albedo_mul.assign(n, 1.0f);
  d->mask.assign(n, 0);
}

/// Integrates the patch: area of masked cells, volume/max/mean of the deficit,
/// each cell weighted by its true surface area (the s spacing stretches with l).
void Measure(const RoadGeometry& road, Damage* d) {
  double vol = 0, area_def = 0, area_mask = 0, mx = 0;
  for (int j = 0; j < d->nl; ++j) {
    const double a = d->res * d->res * road.Stretch(d->l0 + (j + 0.5) * d->res);
    for (int i = 0; i < d->ns; ++i) {
      const size_t k = static_cast<size_t>(j) * d->ns + i;
      const double def = d->deficit_m[k];
      if (def > 0) {
        vol += def * a;
        area_def += a;
        mx = std::max(mx, def);
      }
      if (d->mask[k]) area_mask += a;
    }
  }
  d->volume_m3 = vol;
  d->max_depth_m = mx;
  d->mean_depth_m = area_def > 0 ? vol / area_def : 0;
  d->area_m2 = area_mask;
}

/// Rasterizes a crack polyline of width w into the patch (anti-aliased coverage).
void RasterizeCrack(const std::vector<Eigen::Vector2d>& pts, double w, double depth, double darken, Damage* d,
                    std::vector<float>* coverage) {
  const double res = d->res;
  for (size_t k = 0; k + 1 < pts.size(); ++k) {
    const Eigen::Vector2d a = pts[k], b = pts[k + 1];
    const Eigen::Vector2d ab = b - a;
    const double len2 = std::max(ab.squaredNorm(), 1e-12);
    const double m = w / 2 + 2 * res;
    const int i0 = std::max(0, static_cast<int>((std::min(a.x(), b.x()) - m - d->s0) / res));
    const int i1 = std::min(d->ns - 1, static_cast<int>((std::max(a.x(), b.x()) + m - d->s0) / res));
    const int j0 = std::max(0, static_cast<int>((std::min(a.y(), b.y()) - m - d->l0) / res));
    const int j1 = std::min(d->nl - 1, static_cast<int>((std::max(a.y(), b.y()) + m - d->l0) / res));
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const Eigen::Vector2d p(d->s0 + (i + 0.5) * res, d->l0 + (j + 0.5) * res);
        const double u = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
        const double dist = (p - (a + u * ab)).norm();
        const float c = static_cast<float>(Clamp01((w / 2 - dist) / res + 0.5));
        const size_t idx = static_cast<size_t>(j) * d->ns + i;
        if (c > (*coverage)[idx]) (*coverage)[idx] = c;
        if (dist <= std::max(w / 2, 0.5 * res)) d->mask[idx] = 1;
      }
    }
  }
  for (size_t idx = 0; idx < coverage->size(); ++idx) {
    const float c = (*coverage)[idx];
    if (c > 0) {
      d->deficit_m[idx] = std::max(d->deficit_m[idx], static_cast<float>(depth * c));
      d->albedo_mul[idx] = std::min(d->albedo_mul[idx], static_cast<float>(1 - darken * c));
    }
  }
}

double CrackDepth(double w) { return std::clamp(2.0 * w + 0.005, 0.008, 0.05); }

}  // namespace

void RoadScene::PlaceDamage(const SimulationOptions& o, double s_min, double s_max) {
  Rng rng(HashCombine(static_cast<uint64_t>(o.seed), 11));
  const double res = o.damage_resolution_m;
  const double hw = road_.half_width();
  const double len = std::max(0.0, s_max - s_min);
  std::vector<Box> used;
  auto reserve = [&](const Box& b) {
    if (b.s0 < s_min || b.s1 > s_max || b.l0 < -hw + 0.1 || b.l1 > hw - 0.1) return false;
    for (const Box& u : used) {
      if (u.Overlaps(b, 0.15)) return false;
    }
    used.push_back(b);
    return true;
  };
  // Rough-bottom texture for potholes: two octaves of the scene noise.
  const Octave rough1{0.012, 0.8, 0.6, 100, 300}, rough2{0.045, -0.6, 0.8, 700, 50};

  std::vector<Damage> out;
  const int n_pot = rng.Count(o.potholes_per_100m * len / 100);
  for (int n = 0; n < n_pot; ++n) {
    for (int attempt = 0; attempt < 40; ++attempt) {
      const double diameter = std::exp(rng.Uniform(std::log(0.15), std::log(1.5)));
      const double depth = rng.Uniform(0.015, 0.12);
      const double R = diameter / 2;
      double amp[7] = {0}, ph[7] = {0}, sum = 0;
      for (int k = 2; k <= 6; ++k) {
        amp[k] = rng.Uniform(-1, 1) * 0.13 / std::pow(k, 0.7);
        ph[k] = rng.Uniform(0, 2 * kPi);
        sum += std::abs(amp[k]);
      }
      const double scale = sum > 0.4 ? 0.4 / sum : 1.0;  // keeps r(theta) >= 0.6 R
      const double rmax = R * (1 + sum * scale);
      const double sc = rng.Uniform(s_min + rmax, s_max - rmax);
      const double lc = rng.Uniform(-hw + rmax + 0.15, hw - rmax - 0.15);
      if (!reserve({sc - rmax, sc + rmax, lc - rmax, lc + rmax})) continue;
      auto radius = [&](double th) {
        double r = 1;
        for (int k = 2; k <= 6; ++k) r += scale * amp[k] * std::cos(k * th + ph[k]);
        return R * r;
      };
      Damage d;
      d.type = DamageType::kPothole;
      AllocatePatch(&d, sc - rmax, sc + rmax, lc - rmax, lc + rmax, res);
      for (int j = 0; j < d.nl; ++j) {
        for (int i = 0; i < d.ns; ++i) {
          const double s = d.s0 + (i + 0.5) * res, l = d.l0 + (j + 0.5) * res;
          const double ds = s - sc, dl = l - lc;
          const double q = std::hypot(ds, dl) / radius(std::atan2(dl, ds));
          if (q >= 1) continue;
          const double wall = SmoothStep(0.0, 0.3, 1 - q);
          const double bowl = 1 - 0.25 * q * q;
          const double rough = 0.10 * (rough1.At(*noise_, s, l) - 0.5) + 0.12 * (rough2.At(*noise_, s, l) - 0.5);
          const size_t k = static_cast<size_t>(j) * d.ns + i;
          d.deficit_m[k] = static_cast<float>(std::max(0.0, depth * wall * (bowl + rough * wall)));
          d.albedo_mul[k] = static_cast<float>(1 - 0.42 * wall);  // darker, wetter inside
          d.mask[k] = 1;
        }
      }
      for (int k = 0; k < 72; ++k) {
        const double th = 2 * kPi * k / 72;
        d.outline_sl.emplace_back(sc + radius(th) * std::cos(th), lc + radius(th) * std::sin(th));
      }
      Measure(road_, &d);
      d.mean_diameter_m = 2 * std::sqrt(d.area_m2 / kPi);
      d.severity = PotholeSeverityAstm(d.max_depth_m, d.mean_diameter_m);
      if (d.severity.empty()) d.severity = "none";
      d.severity_standard = "ASTM D6433 pothole (max depth x mean diameter)";
      out.push_back(std::move(d));
      break;
    }
  }

  const int n_crack = rng.Count(o.cracks_per_100m * len / 100);
  for (int n = 0; n < n_crack; ++n) {
    const bool longitudinal = rng.Uniform() < 0.5;
    for (int attempt = 0; attempt < 40; ++attempt) {
      const double w = std::exp(rng.Uniform(std::log(0.002), std::log(0.025)));
      std::vector<Eigen::Vector2d> pts;
      if (longitudinal) {
        const double L = rng.Uniform(1.5, 6.0);
        double s = rng.Uniform(s_min, s_max - L), l = rng.Uniform(-hw + 0.5, hw - 0.5), drift = 0;
        for (double u = 0; u <= L + 1e-9; u += 0.05) {
          pts.emplace_back(s + u, l);
          drift = 0.9 * drift + rng.Normal() * 0.004;
          l = std::clamp(l + drift + rng.Normal() * 0.003, -hw + 0.3, hw - 0.3);
        }
      } else {
        const double L = rng.Uniform(1.5, std::min(2 * hw - 0.8, 6.0));
        double l = rng.Uniform(-hw + 0.4, hw - 0.4 - L), s = rng.Uniform(s_min + 0.3, s_max - 0.3), drift = 0;
        for (double u = 0; u <= L + 1e-9; u += 0.05) {
          pts.emplace_back(s, l + u);
          drift = 0.9 * drift + rng.Normal() * 0.004;
          s += drift + rng.Normal() * 0.003;
        }
      }
      Box b{1e9, -1e9, 1e9, -1e9};
      for (const auto& p : pts) {
        b.s0 = std::min(b.s0, p.x() - w);
        b.s1 = std::max(b.s1, p.x() + w);
        b.l0 = std::min(b.l0, p.y() - w);
        b.l1 = std::max(b.l1, p.y() + w);
      }
      if (!reserve(b)) continue;
      Damage d;
      d.type = longitudinal ? DamageType::kCrackLongitudinal : DamageType::kCrackTransverse;
      AllocatePatch(&d, b.s0, b.s1, b.l0, b.l1, res);
      std::vector<float> cov(d.deficit_m.size(), 0.0f);
      RasterizeCrack(pts, w, CrackDepth(w), 0.75, &d, &cov);
      Measure(road_, &d);
      d.outline_sl = pts;
      d.width_m = w;
      d.length_m = 0;
      for (size_t k = 0; k + 1 < pts.size(); ++k) {
        d.length_m += (pts[k + 1] - pts[k]).norm() * road_.Stretch(0.5 * (pts[k].y() + pts[k + 1].y()));
      }
      d.area_m2 = d.length_m * w;
      d.mean_depth_m = d.volume_m3 / d.area_m2;
      d.severity = CrackSeverityFhwa(w);
      d.severity_standard = "FHWA LTPP crack width";
      out.push_back(std::move(d));
      break;
    }
  }

  const int n_alli = rng.Count(o.alligator_per_100m * len / 100);
  for (int n = 0; n < n_alli; ++n) {
    for (int attempt = 0; attempt < 40; ++attempt) {
      const double S = rng.Uniform(1.0, 3.0), W = rng.Uniform(0.8, 2.0);
      const double s0 = rng.Uniform(s_min, s_max - S), l0 = rng.Uniform(-hw + 0.2, hw - 0.2 - W);
      if (!reserve({s0, s0 + S, l0, l0 + W})) continue;
      const double w = std::exp(rng.Uniform(std::log(0.002), std::log(0.010)));
      const double g = rng.Uniform(0.12, 0.3);
      Damage d;
      d.type = DamageType::kAlligator;
      AllocatePatch(&d, s0, s0 + S, l0, l0 + W, res);
      // Jittered seeds; cracks run along the Voronoi cell borders.
      const int gs = static_cast<int>(std::ceil(S / g)) + 3, gl = static_cast<int>(std::ceil(W / g)) + 3;
      std::vector<Eigen::Vector2d> seeds(static_cast<size_t>(gs) * gl);
      for (int b = 0; b < gl; ++b) {
        for (int a = 0; a < gs; ++a) {
          seeds[static_cast<size_t>(b) * gs + a] =
              Eigen::Vector2d(s0 + (a - 1 + rng.Uniform(0.1, 0.9)) * g, l0 + (b - 1 + rng.Uniform(0.1, 0.9)) * g);
        }
      }
      const double depth = CrackDepth(w);
      for (int j = 0; j < d.nl; ++j) {
        for (int i = 0; i < d.ns; ++i) {
          const Eigen::Vector2d p(d.s0 + (i + 0.5) * res, d.l0 + (j + 0.5) * res);
          if (p.x() < s0 || p.x() > s0 + S || p.y() < l0 || p.y() > l0 + W) continue;
          const int a = static_cast<int>((p.x() - s0) / g) + 1, b = static_cast<int>((p.y() - l0) / g) + 1;
          double d1 = 1e9, d2 = 1e9;
          Eigen::Vector2d q1 = Eigen::Vector2d::Zero(), q2 = Eigen::Vector2d::Zero();
          for (int bb = std::max(0, b - 1); bb <= std::min(gl - 1, b + 1); ++bb) {
            for (int aa = std::max(0, a - 1); aa <= std::min(gs - 1, a + 1); ++aa) {
              const Eigen::Vector2d& q = seeds[static_cast<size_t>(bb) * gs + aa];
              const double dd = (p - q).squaredNorm();
              if (dd < d1) {
                d2 = d1, q2 = q1, d1 = dd, q1 = q;
              } else if (dd < d2) {
                d2 = dd, q2 = q;
              }
            }
          }
          const double dist = (d2 - d1) / (2 * (q2 - q1).norm());
          const double c = Clamp01((w / 2 - dist) / res + 0.5);
          const size_t k = static_cast<size_t>(j) * d.ns + i;
          d.mask[k] = 1;
          d.deficit_m[k] = static_cast<float>(depth * c);
          d.albedo_mul[k] = static_cast<float>(0.92 * (1 - 0.7 * c));
        }
      }
      Measure(road_, &d);
      d.outline_sl = {{s0, l0}, {s0 + S, l0}, {s0 + S, l0 + W}, {s0, l0 + W}};
      d.width_m = w;
      d.severity = CrackSeverityFhwa(w);
      d.severity_standard = "FHWA LTPP crack width";
      out.push_back(std::move(d));
      break;
    }
  }

  const int n_patch = rng.Count(o.patches_per_100m * len / 100);
  for (int n = 0; n < n_patch; ++n) {
    for (int attempt = 0; attempt < 40; ++attempt) {
      const double S = rng.Uniform(0.8, 3.0), W = rng.Uniform(0.8, 2.5);
      const double s0 = rng.Uniform(s_min, s_max - S), l0 = rng.Uniform(-hw + 0.2, hw - 0.2 - W);
      if (!reserve({s0, s0 + S, l0, l0 + W})) continue;
      const double tone = rng.Uniform() < 0.5 ? 0.72 : 1.3;  // fresh dark or old light asphalt
      Damage d;
      d.type = DamageType::kPatch;
      AllocatePatch(&d, s0, s0 + S, l0, l0 + W, res);
      for (int j = 0; j < d.nl; ++j) {
        for (int i = 0; i < d.ns; ++i) {
          const double s = d.s0 + (i + 0.5) * res, l = d.l0 + (j + 0.5) * res;
          const double inside = std::min({s - s0, s0 + S - s, l - l0, l0 + W - l});
          if (inside < 0) continue;
          const size_t k = static_cast<size_t>(j) * d.ns + i;
          const double ramp = Clamp01(inside / 0.01);
          d.deficit_m[k] = static_cast<float>(-0.003 * ramp);  // raised 3 mm
          d.albedo_mul[k] = static_cast<float>(1 + (tone - 1) * ramp);
          d.mask[k] = 1;
        }
      }
      Measure(road_, &d);
      d.outline_sl = {{s0, l0}, {s0 + S, l0}, {s0 + S, l0 + W}, {s0, l0 + W}};
      d.severity = "L";
      d.severity_standard = "ASTM D6433 patching (simulated patches are intact)";
      out.push_back(std::move(d));
      break;
    }
  }
  for (size_t k = 0; k < out.size(); ++k) out[k].id = static_cast<int>(k) + 1;
  damages_ = std::move(out);
}

void RoadScene::PlaceObstacles(const SimulationOptions& o, double s_min, double s_max) {
  Rng rng(HashCombine(static_cast<uint64_t>(o.seed), 13));
  const double hw = road_.half_width();
  for (int k = 0; k < o.parked_cars; ++k) {
    Obstacle ob;
    ob.kind = Obstacle::Kind::kBox;
    ob.name = "car " + std::to_string(k + 1);
    const double s = rng.Uniform(s_min + 2.5, std::max(s_min + 2.5, s_max - 2.5));
    const double l = (rng.Uniform() < 0.5 ? -1 : 1) * (hw - 1.1);
    const Eigen::Vector2d xy = road_.ToWorld(s, l);
    ob.half_size = Eigen::Vector3d(2.2, 0.9, 0.72);
    ob.centre = Eigen::Vector3d(xy.x(), xy.y(), road_.IntactZ(s, l) + ob.half_size.z() + 0.02);
    ob.R_world_obj = Eigen::AngleAxisd(road_.HeadingRad(s), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const double tones[] = {0.12, 0.45, 0.7};
    ob.albedo = static_cast<float>(tones[rng.Next() % 3]);
    obstacles_.push_back(ob);
  }
  for (int k = 0; k < o.people; ++k) {
    Obstacle ob;
    ob.kind = Obstacle::Kind::kCylinder;
    ob.name = "person " + std::to_string(k + 1);
    const double s = rng.Uniform(s_min + 1, std::max(s_min + 1, s_max - 1));
    const double l = rng.Uniform(-hw + 0.6, hw - 0.6);
    const Eigen::Vector2d xy = road_.ToWorld(s, l);
    ob.half_size = Eigen::Vector3d(0.25, 0.25, 1.75);
    ob.centre = Eigen::Vector3d(xy.x(), xy.y(), road_.IntactZ(s, l));
    ob.albedo = 0.35f;
    obstacles_.push_back(ob);
  }
}

}  // namespace rs::sim
