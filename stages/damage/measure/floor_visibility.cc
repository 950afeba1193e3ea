#include "stages/damage/measure/floor_visibility.h"

#include "stages/damage/measure/measure.h"
#include "survey/stats/order_statistic.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <vector>

namespace rs {
namespace {

// One labelled pixel in road coordinates: where its ray crosses the road (x along the view,
// y across it), the tangent of its elevation over the road, and the seen depth (NaN: none).
struct RayPoint {
  double x, y, tan_e, depth_m;
  int strip = 0;
};

// Per lateral strip: the near rim (the nearest crossing) and the tangent of the ray over it.
struct Strip {
  double x_rim = 1e300, tan_rim = 0;
  double shadow_edge_depth_m = 0;               ///< deepest seen depth of the rays grazing the rim (on the shadow line)
  double deep_start_m = 1e300;                  ///< clearance where the strip first sees the deepest part
  std::vector<std::pair<double, double>> seen;  ///< (along-view position, depth) of the seen points
};

// Volume per metre of width the shadow of one strip can hide beyond what the measurement
// already holds. The stretch [0, L] behind the rim is seen by no ray; its floor lies below the
// shadow line (depth > x·tan e) and, with walls no steeper than `slope` on average, above the
// "V" between its two seen ends, min(slope·x, d + slope·(L − x)) (d: the depth where the
// grazing rays meet the surface), and above `cap`. The measured volume (crossing area × seen
// depth) already counts the shadow triangle d·L/2: integrating depth over where the rays cross
// the road maps [0, x_far] onto the seen part [L, x_far] and adds d²/(2 tan e).
double HiddenExtraArea(double length_m, double seen_m, double slope, double cap_m) {
  constexpr int kSteps = 64;
  double area = 0;
  for (int i = 0; i < kSteps; ++i) {
    const double x = (i + 0.5) * length_m / kSteps;
    area += std::min({slope * x, seen_m + slope * (length_m - x), cap_m});
  }
  return std::max(0.0, area * length_m / kSteps - seen_m * length_m / 2);
}

// The seen profile's depth at along-view position x: linear between the seen points around x
// (sorted by position); 0 beyond the last one.
double SeenDepthAt(const std::vector<std::pair<double, double>>& seen, double x) {
  const auto it = std::lower_bound(seen.begin(), seen.end(), std::make_pair(x, -1e300));
  if (it == seen.end()) return 0;
  if (it == seen.begin()) return it->second;
  const auto& [x1, d1] = *it;
  const auto& [x0, d0] = *(it - 1);
  return x1 - x0 > 1e-12 ? d0 + (d1 - d0) * (x - x0) / (x1 - x0) : d1;
}

// The far wall's mean slope (depth gained per metre towards the centre) over the seen points
// from x_grazing on whose depth lies in [lo, hi]: least squares of depth on position. NaN with
// fewer than three points.
double FarWallSlope(const std::vector<std::pair<double, double>>& seen, double x_grazing, double lo_m, double hi_m) {
  double n = 0, sx = 0, sd = 0, sxx = 0, sxd = 0;
  for (const auto& [x, d] : seen) {
    if (x < x_grazing || d < lo_m || d > hi_m) continue;
    n += 1, sx += x, sd += d, sxx += x * x, sxd += x * d;
  }
  const double var = sxx - sx * sx / std::max(n, 1.0);
  if (n < 3 || var < 1e-12) return kUnknown;
  return -(sxd - sx * sd / n) / var;
}

// How the seen far wall runs into the shadow, pooled over a detection's strips (medians): its
// mean slope over the middle (30-70 % of the grazing depth) and the lower part (70-100 %).
// Only a wall steeper than the rays over the rim (`ray_slope`) is read: mirrored onto the near
// side, a shallower one would hide no floor, so it is not the wall but the disparity's smoothing
// of it.
struct WallTrend {
  double mid = kUnknown, low = kUnknown, ray_slope = kUnknown;
  /// The slope declines towards the grazing point: where it reaches zero is a floor.
  bool Declining() const { return mid > ray_slope && low >= 0 && low < mid; }
};

// The hidden stretch of one strip completed: the area under the estimated profile over [0, L]
// behind the rim, and its deepest point. Assumption (docs/stages/damage.md "Hidden floors"): a
// pothole is a bowl, symmetric along the strip about the opening's centre c (its ends x_near,
// x_far: where the surface is seen 5 % of the max depth deep), so the hidden point at x is as
// deep as the seen point at 2c − x on the far wall. Where that mirror point is hidden too (the
// shadow reaches past the centre: the floor is hidden) the bowl is the circle through the two
// rims and the grazing point (where the grazing rays meet the far wall, depth d): the one
// bowl these three seen points fix, exact for a spherical cap. Where the far wall's slope
// already declines towards the grazing point (`trend`), the floor is no deeper than where that
// decline reaches zero slope: the slope² taken linear in depth (a smooth floor is locally a
// parabola, of constant curvature), continued from the grazing point to its vertex and flat
// beyond; the completion takes the shallower of the two. Every estimate is kept deeper than
// the shadow line (a hidden point lies below the grazing ray) and no deeper than `ceiling_m`
// (the strip's depth bound).
struct Completion {
  double area_m2 = 0;  ///< ∫ depth over the hidden stretch (per metre of width)
  double max_depth_m = 0;
};
Completion CompleteHidden(const std::vector<std::pair<double, double>>& seen, double x_rim, double tan_e,
                          double seen_depth_m, double x_near, double x_far, const WallTrend& trend, double ceiling_m) {
  constexpr int kSteps = 64;
  Completion c;
  const double length = seen_depth_m / tan_e, x_grazing = x_rim + length, centre = (x_near + x_far) / 2;
  const double half = (x_far - x_near) / 2, t_grazing = x_grazing - centre;
  // The circle through (±half, 0) and (t_grazing, d): centre `k` above the road, radius² = half² + k².
  const double k = (half * half - t_grazing * t_grazing - seen_depth_m * seen_depth_m) / (2 * seen_depth_m);
  // The far wall continued: the band slopes stand at 50 % and 85 % of d, so the curvature is
  // (mid² − low²) / (2 · 0.35 d) and the slope at the grazing point follows from the low band's.
  double curvature = 0, slope_g = 0, floor_m = 1e300, run_m = 0;
  if (trend.Declining()) {
    curvature = (trend.mid * trend.mid - trend.low * trend.low) / (2 * 0.35 * seen_depth_m);
    slope_g = std::sqrt(std::max(0.0, trend.low * trend.low - 2 * curvature * 0.15 * seen_depth_m));
    run_m = slope_g / curvature;  // from the grazing point to the vertex
    floor_m = seen_depth_m + slope_g * run_m / 2;
  }
  for (int i = 0; i < kSteps; ++i) {
    const double s = (i + 0.5) * length / kSteps, x = x_rim + s, mirror = 2 * centre - x;
    double d;
    if (mirror >= x_grazing) {
      d = SeenDepthAt(seen, mirror);
    } else {  // x and its mirror both hidden: |x − c| < t_grazing
      const double t = x - centre;
      d = std::sqrt(std::max(0.0, half * half + k * k - t * t)) - k;
      const double tau = t_grazing - std::abs(t);  // towards the centre from the grazing point
      if (trend.Declining())
        d = std::min(d, tau >= run_m ? floor_m : seen_depth_m + tau * (slope_g - curvature * tau / 2));
    }
    d = std::min(std::max(d, s * tan_e), ceiling_m);
    c.area_m2 += d * length / kSteps;
    c.max_depth_m = std::max(c.max_depth_m, d);
  }
  return c;
}

// The instance's pixels as rays: where each crosses the road, its horizontal offset from the
// camera's foot on the plane, and the sums the analysis averages.
struct RayCloud {
  std::vector<RayPoint> pts;
  std::vector<Eigen::Vector3d> horizontal;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  double z_sum = 0, n_dot_ray_sum = 0;
};

RayCloud CollectRays(const cv::Mat& labels, int id, const cv::Rect& box, const RoadRelief& r, const RectifiedStereo& g,
                     const RoadSurface& s) {
  RayCloud rc;
  std::vector<RayPoint>& pts = rc.pts;
  const Eigen::Vector3d n = s.normal;                  // unit, towards the camera
  const Eigen::Vector3d foot = n.dot(s.origin_m) * n;  // the camera centre (origin) dropped onto the plane
  for (int v = box.y; v < box.y + box.height; ++v) {
    const uint16_t* l = labels.ptr<uint16_t>(v);
    const float* zr = r.road_depth_m.ptr<float>(v);
    const float* dr = r.depth_below_mm.ptr<float>(v);
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (l[u] != id || !std::isfinite(zr[u])) continue;
      const Eigen::Vector3d ray((u - g.cx_px) / g.f_px, (v - g.cy_px) / g.f_px, 1.0);
      const Eigen::Vector3d p = double(zr[u]) * ray;  // where the ray crosses the road
      Eigen::Vector3d h = p - foot;
      h -= n * n.dot(h);
      const double sin_e = std::abs(n.dot(ray.normalized()));
      const double tan_e = sin_e / std::max(1e-9, std::sqrt(1 - sin_e * sin_e));
      pts.push_back({0, 0, tan_e, std::isfinite(dr[u]) ? dr[u] / 1000.0 : kUnknown});
      rc.horizontal.push_back(h);
      rc.mean += h;
      rc.z_sum += zr[u];
      rc.n_dot_ray_sum += std::abs(n.dot(ray));
    }
  }
  return rc;
}

// What the shadows behind the strips' near rims may hide: the depth bound, the hidden volume
// and its completed estimate, per strip along the view.
struct HiddenStretches {
  double bound = 0, hidden_volume = 0, longest = 0, completed_volume = 0;
  std::vector<double> strip_max;  // completed max depth per strip with a shadow (in strip order)
};

HiddenStretches CompleteStrips(std::vector<Strip>& strips, double tan_rim, double slope, double cap,
                               double sigma_height_m, double strip_m, double rim_seen_m) {
  // The far wall's trend, pooled over the strips (one strip's wall is a handful of rows).
  std::vector<double> mids, lows;
  for (Strip& st : strips) {
    const double d = st.shadow_edge_depth_m;
    if (!(d > 0) || !(st.tan_rim > 0)) continue;
    std::sort(st.seen.begin(), st.seen.end());
    const double x_grazing = st.x_rim + d / st.tan_rim;
    const double mid = FarWallSlope(st.seen, x_grazing, 0.3 * d, 0.7 * d),
                 low = FarWallSlope(st.seen, x_grazing, 0.7 * d, d);
    if (mid > 0 && std::isfinite(low)) mids.push_back(mid), lows.push_back(low);
  }
  WallTrend trend;
  if (!mids.empty()) {
    trend.mid = LowerMedianInPlace(mids), trend.low = LowerMedianInPlace(lows), trend.ray_slope = tan_rim;
  }
  HiddenStretches out;
  for (Strip& st : strips) {
    const double d = st.shadow_edge_depth_m;
    if (!(d > 0) || !(st.tan_rim > 0)) continue;
    const double length = d / st.tan_rim;
    out.longest = std::max(out.longest, length);
    // The bound's own noise: d carries the height noise, scaled like the bound.
    const double gain = std::max(1.0, (slope / st.tan_rim + 1) / 2);
    const double upper = std::min(cap, gain * (d + 2 * sigma_height_m));
    out.bound = std::max(out.bound, gain * (d + 2 * sigma_height_m));
    out.hidden_volume += strip_m * HiddenExtraArea(length, d, slope, upper);

    // The estimate: the opening's ends on the road where the seen surface is 5 % of the max
    // depth deep (the near one no farther than the rim).
    double x_near = st.x_rim, x_far = st.x_rim + length;
    for (const auto& [x, depth] : st.seen)
      if (depth >= rim_seen_m) x_near = std::min(x_near, x), x_far = std::max(x_far, x);
    // The estimate's ceiling is the depth bound alone, not the bound's V: the near wall follows
    // the mirrored far wall even where that is steeper than the bound's slope (an assumption
    // made for a safe interval; the mirror is what the frame shows). The volume is capped below.
    const Completion c = CompleteHidden(st.seen, st.x_rim, st.tan_rim, d, x_near, x_far, trend, upper);
    // The measured volume already holds the shadow triangle d·L/2 (HiddenExtraArea).
    out.completed_volume += strip_m * std::max(0.0, c.area_m2 - d * length / 2);
    out.strip_max.push_back(c.max_depth_m);
  }
  return out;
}

}  // namespace

FloorVisibility AnalyseFloorVisibility(const cv::Mat& labels, int id, const cv::Rect& box, const RoadRelief& r,
                                       const RectifiedStereo& g, const RoadSurface& s, const MeasureOptions& o,
                                       double max_depth_m, double volume_m3, double area_m2, double sigma_depth_m) {
  FloorVisibility out;
  if (!(max_depth_m > 0) || box.empty()) return out;
  RayCloud rays = CollectRays(labels, id, box, r, g, s);
  std::vector<RayPoint>& pts = rays.pts;
  const std::vector<Eigen::Vector3d>& horizontal = rays.horizontal;
  Eigen::Vector3d& mean = rays.mean;
  const double z_sum = rays.z_sum, n_dot_ray_sum = rays.n_dot_ray_sum;
  const Eigen::Vector3d n = s.normal;  // unit, towards the camera
  if (pts.empty()) return out;
  out.analysed = true;
  out.max_depth_estimate_m = max_depth_m, out.volume_estimate_m3 = volume_m3;  // until a shadow says more
  const double z_mean = z_sum / pts.size();
  // Height noise of a seen point: a range error ΔZ moves it along its ray by ΔZ·|n·ray|.
  const double sigma_height_m = sigma_depth_m * n_dot_ray_sum / pts.size();
  mean /= double(pts.size());
  if (mean.norm() < 1e-6) {  // straight below the camera: every ray is steep, nothing hides
    out.grazing_angle_deg = 90;
    return out;
  }
  const Eigen::Vector3d along = mean.normalized(), across = n.cross(along);
  for (size_t i = 0; i < pts.size(); ++i) pts[i].x = along.dot(horizontal[i]), pts[i].y = across.dot(horizontal[i]);

  // Lateral strips 1.5 pixels wide (a pixel covers Z/f across the view): each holds about one
  // image column. Its near rim is where the rays first see the depression (the nearest crossing
  // seeing a quarter of the max depth): the label itself starts a row or two nearer (the rim
  // extension, the smoothing's halo), which would count as clearance. Behind a rim that hides
  // the floor the depth jumps there to the shadow line; over a visible wall it rises gradually.
  const double strip_m = 1.5 * z_mean / g.f_px;
  const double rim_depth_m = 0.25 * max_depth_m;
  double y_min = 1e300, y_max = -1e300;
  for (const RayPoint& p : pts) y_min = std::min(y_min, p.y), y_max = std::max(y_max, p.y);
  std::vector<Strip> strips(static_cast<size_t>((y_max - y_min) / strip_m) + 1);
  for (RayPoint& p : pts) p.strip = std::min(static_cast<int>((p.y - y_min) / strip_m), int(strips.size()) - 1);
  auto strip_of = [&](const RayPoint& p) -> Strip& { return strips[p.strip]; };
  for (const RayPoint& p : pts) {
    if (!(p.depth_m >= rim_depth_m)) continue;  // NaN: no depth seen
    Strip& st = strip_of(p);
    if (p.x < st.x_rim) st.x_rim = p.x, st.tan_rim = p.tan_e;
  }
  // Clearance of a seen point: the shadow line at its position minus its depth. The point lies
  // d/tan e behind its own crossing, so the clearance is (crossing − rim)·tan e: fixed by the
  // pixel and the road model, not by the (noisy) range; one image row adds about Z/f.
  auto clearance = [&](const RayPoint& p, const Strip& st) {
    const double x_hit = p.x + p.depth_m / p.tan_e;
    return (x_hit - st.x_rim) * st.tan_rim - p.depth_m;
  };
  const double margin_m = o.floor_clearance_px * z_mean / g.f_px;
  // The rays grazing the rim: the first two rows behind it (the relief is smoothed over about
  // three rows along the view at a car's range), or behind where the deepest part begins.
  const double edge_m = 2 * z_mean / g.f_px;
  // The deepest seen part (within 10 % of the max depth or the height noise). The floor counts
  // as seen when that part reaches the margin farther from the shadow line than where it
  // begins: a floor is seen over a stretch, while the deepest seen points of a hidden floor are
  // where the grazing rays meet the far wall, one row on the shadow line. With exact disparity
  // the deepest part begins on the shadow line (the walls are steeper than the rays), so this
  // is the clearance itself; a disparity smoothed along the view moves that row a few rows off
  // the rim and spreads it (as far as seen floors reach), which measuring from where it
  // begins cancels. Where it begins: the median over the strips of each strip's
  // nearest deep point (one strip's noise does not move it).
  const double deep_m = max_depth_m - std::max(0.1 * max_depth_m, sigma_height_m);
  double best_clearance = -1e300, tan_sum = 0;
  int tan_n = 0;
  for (const RayPoint& p : pts) {
    if (!(p.depth_m >= rim_depth_m)) continue;
    Strip& st = strip_of(p);
    const double c = clearance(p, st);
    if (p.depth_m >= deep_m) {
      best_clearance = std::max(best_clearance, c);
      st.deep_start_m = std::min(st.deep_start_m, c);
      tan_sum += st.tan_rim, ++tan_n;
    }
  }
  if (tan_n == 0) return out;
  const double tan_rim = tan_sum / tan_n;
  std::vector<double> starts;
  for (const Strip& st : strips)
    if (st.deep_start_m < 1e300) starts.push_back(st.deep_start_m);
  const double deep_start_m = std::max(0.0, LowerMedianInPlace(starts));
  // The grazing rays' depth, from as far behind the rim as the smoothing moved the deepest
  // part (rows nearer the rim mix the road in and lower the bound).
  const double edge_band_m = edge_m + deep_start_m;
  for (const RayPoint& p : pts) {
    if (!(p.depth_m >= rim_depth_m)) continue;
    Strip& st = strip_of(p);
    if (clearance(p, st) < edge_band_m) st.shadow_edge_depth_m = std::max(st.shadow_edge_depth_m, p.depth_m);
  }
  out.grazing_angle_deg = std::atan(tan_rim) * 180.0 / CV_PI;
  out.rim_clearance_m = best_clearance;
  out.floor_visible = best_clearance - deep_start_m >= margin_m;
  // Per strip the stretch behind the rim no ray reaches ends where the grazing rays meet the
  // surface (depth d at d/tan e). Between the rim (depth 0) and that point the floor can be no
  // deeper than walls of the assumed slope allow from both ends. A seen floor caps it: that
  // stretch holds volume (the near wall's wedge) but, the floor being seen, no deeper point.
  const double slope = o.hidden_wall_slope;
  // The stated interval of a seen max depth is ±2 σ_Z (σ_Z, not the smaller height noise: the
  // disparity's errors at a rim are not those of a flat road).
  const double cap = out.floor_visible ? max_depth_m + 2 * sigma_depth_m : 1e300;
  // The seen profile of each strip, by where the rays meet the surface (x_hit).
  const double rim_seen_m = 0.05 * max_depth_m;  // the openings' ends: the same depth on both sides
  for (const RayPoint& p : pts)
    if (std::isfinite(p.depth_m)) strip_of(p).seen.emplace_back(p.x + p.depth_m / p.tan_e, p.depth_m);
  const HiddenStretches hidden = CompleteStrips(strips, tan_rim, slope, cap, sigma_height_m, strip_m, rim_seen_m);
  const double bound = hidden.bound, hidden_volume = hidden.hidden_volume, longest = hidden.longest;
  const double completed_volume = hidden.completed_volume;
  const std::vector<double>& strip_max = hidden.strip_max;
  out.hidden_length_m = longest;
  const double volume_noise = 2 * sigma_depth_m * area_m2;  // the lower bound's term, stated alike
  // The volume counts as seen when the shadow could hide at most 5 % of it (a third of the
  // 15 % a volume is graded by); the stereo noise is stated apart (σ_Z).
  if (!out.floor_visible || hidden_volume > 0.05 * volume_m3)
    out.volume_upper_m3 = volume_m3 + hidden_volume + volume_noise;
  out.volume_estimate_m3 = volume_m3 + completed_volume;
  if (std::isfinite(out.volume_upper_m3))  // the estimate stays inside the stated interval
    out.volume_estimate_m3 = std::min(out.volume_estimate_m3, out.volume_upper_m3);
  if (!out.floor_visible) {
    out.max_depth_bound_m = std::max(bound, max_depth_m + 2 * sigma_depth_m);
    // The deepest completed strip, as the median of three neighbours (one strip's rims, a row
    // off, are not the pothole's depth).
    for (size_t i = 1; i + 1 < strip_max.size(); ++i) {
      double m3[3] = {strip_max[i - 1], strip_max[i], strip_max[i + 1]};
      std::sort(m3, m3 + 3);
      out.max_depth_estimate_m = std::max(out.max_depth_estimate_m, m3[1]);
    }
  }
  return out;
}

void AnalyseFloorVisibility(std::vector<DamageInstance>& instances, const cv::Mat& labels, const RoadRelief& r,
                            const RectifiedStereo& g, const RoadSurface& s, const MeasureOptions& o) {
  const std::vector<cv::Rect> boxes = LabelBoxes(labels);
  for (DamageInstance& d : instances) {
    if (d.type == DamageType::kCrack) continue;
    d.max_depth_seen_m = d.max_depth_m, d.volume_seen_m3 = d.volume_m3;
    if (!std::isfinite(d.max_depth_m) || d.id >= static_cast<int>(boxes.size())) continue;
    const FloorVisibility f = AnalyseFloorVisibility(labels, d.id, boxes[d.id], r, g, s, o, d.max_depth_m, d.volume_m3,
                                                     d.area_m2, d.sigma_depth_m);
    if (!f.analysed) continue;
    d.floor_visible = f.floor_visible;
    d.max_depth_m = f.max_depth_estimate_m;
    d.volume_m3 = f.volume_estimate_m3;
    d.grazing_angle_deg = f.grazing_angle_deg;
    d.hidden_length_m = f.hidden_length_m;
    d.max_depth_bound_m = f.max_depth_bound_m;
    d.volume_upper_m3 = f.volume_upper_m3;
  }
}

}  // namespace rs
