#include "stages/damage/measure/measure.h"

#include "stages/damage/measure/measurement_sigma.h"
#include "survey/stats/order_statistic.h"
#include "survey/stats/robust_stats.h"
#include "stages/damage/noise/scale_noise.h"
#include "stages/damage/road/relief_smooth.h"

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace rs {

double StereoDepthSigma(double z_m, double sigma_d, const RectifiedStereo& g) {
  return z_m * z_m * sigma_d / (g.f_px * g.baseline_m);
}

cv::Mat PixelAreaOnRoad(const RoadRelief& r, const RectifiedStereo& g, const RoadSurface& s) {
  cv::Mat area(r.road_depth_m.size(), CV_32F);
  const double k = 1.0 / (g.f_px * g.f_px * std::max(s.camera_height_m, 1e-9));
  tbb::parallel_for(0, area.rows, [&](int v) {
    const float* z = r.road_depth_m.ptr<float>(v);
    float* a = area.ptr<float>(v);
    for (int u = 0; u < area.cols; ++u) a[u] = static_cast<float>(double(z[u]) * z[u] * z[u] * k);
  });
  return area;
}

std::vector<cv::Rect> LabelBoxes(const cv::Mat& labels) {
  if (labels.type() != CV_16UC1) throw std::invalid_argument("LabelBoxes: labels must be CV_16U");
  struct Box {
    int u0 = INT_MAX, v0 = INT_MAX, u1 = -1, v1 = -1;
  };
  // Bands of rows in parallel, merged afterwards (min/max: the same boxes for any split).
  constexpr int kBands = 8;
  std::vector<std::vector<Box>> band(kBands, std::vector<Box>(1));
  tbb::parallel_for(0, kBands, [&](int k) {
    std::vector<Box>& b = band[k];
    const int v0 = labels.rows * k / kBands, v1 = labels.rows * (k + 1) / kBands;
    for (int v = v0; v < v1; ++v) {
      const uint16_t* l = labels.ptr<uint16_t>(v);
      // Runs of one id update its box once: most of a frame is road (skipped 16 labels at a
      // time), the rest mostly runs across a depression.
      for (int u = 0; u < labels.cols;) {
        if (u + 16 <= labels.cols) {
          uint64_t w[4];
          std::memcpy(w, l + u, sizeof w);
          if (!(w[0] | w[1] | w[2] | w[3])) {
            u += 16;
            continue;
          }
        }
        const int id = l[u];
        int end = u + 1;  // one past the run
        while (end < labels.cols && l[end] == id) ++end;
        if (id) {
          if (id >= static_cast<int>(b.size())) b.resize(id + 1);
          Box& x = b[id];
          x.u0 = std::min(x.u0, u), x.u1 = std::max(x.u1, end - 1), x.v0 = std::min(x.v0, v), x.v1 = std::max(x.v1, v);
        }
        u = end;
      }
    }
  });
  std::vector<Box> b(1);
  for (const std::vector<Box>& bb : band) {
    if (bb.size() > b.size()) b.resize(bb.size());
    for (size_t i = 1; i < bb.size(); ++i) {
      Box& x = b[i];
      x.u0 = std::min(x.u0, bb[i].u0), x.u1 = std::max(x.u1, bb[i].u1);
      x.v0 = std::min(x.v0, bb[i].v0), x.v1 = std::max(x.v1, bb[i].v1);
    }
  }
  std::vector<cv::Rect> out(b.size());
  for (size_t i = 1; i < b.size(); ++i)
    if (b[i].u1 >= 0) out[i] = cv::Rect(b[i].u0, b[i].v0, b[i].u1 - b[i].u0 + 1, b[i].v1 - b[i].v0 + 1);
  return out;
}

std::vector<cv::Point> OutlineOf(const cv::Mat& labels, int id) {
  return OutlineOf(labels, id, cv::Rect({}, labels.size()));
}

std::vector<cv::Point> OutlineOf(const cv::Mat& labels, int id, const cv::Rect& box) {
  const cv::Rect roi = cv::Rect(box.x - 1, box.y - 1, box.width + 2, box.height + 2) & cv::Rect({}, labels.size());
  if (roi.empty()) return {};
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(labels(roi) == id, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, roi.tl());
  if (contours.empty()) return {};
  auto biggest = std::max_element(contours.begin(), contours.end(),
                                  [](const auto& a, const auto& b) { return cv::contourArea(a) < cv::contourArea(b); });
  std::vector<cv::Point> poly;
  cv::approxPolyDP(*biggest, poly, 1.0, true);
  return poly;
}

namespace {

// Distance (CV_32F) of every non-zero pixel of `mask` to its nearest zero pixel, in road units of
// one column's width: a row counts `rows_per_px` (the road length of a pixel along the column
// over its width across, rounded; 1 = square pixels). The mask is stretched row-wise, the
// distance taken there and read back at each row's centre.
cv::Mat RoadDistance(const cv::Mat& mask, int rows_per_px) {
  cv::Mat dist;
  if (rows_per_px <= 1) {
    cv::distanceTransform(mask, dist, cv::DIST_L2, cv::DIST_MASK_5);
    return dist;
  }
  cv::Mat tall, tall_dist;
  cv::resize(mask, tall, cv::Size(mask.cols, mask.rows * rows_per_px), 0, 0, cv::INTER_NEAREST);
  cv::distanceTransform(tall, tall_dist, cv::DIST_L2, cv::DIST_MASK_5);
  dist.create(mask.size(), CV_32F);
  for (int v = 0; v < mask.rows; ++v) tall_dist.row(v * rows_per_px + rows_per_px / 2).copyTo(dist.row(v));
  return dist;
}

// Robust plane depth = c0 + c1·u + c2·v (mm) through samples (u, v, depth): least squares, then
// three times again over the samples at most 3 σ deeper than the fit, σ from the shallower side
// (damage reaching into the ring, e.g. where the segmentation's outline sits off the depression,
// only adds depth; the road's noise is symmetric). Returns false when degenerate.
bool FitDepthPlane(const std::vector<cv::Point3f>& pts, double c[3], double* sigma) {
  auto residual = [&](const cv::Point3f& p) { return p.z - (c[0] + c[1] * p.x + c[2] * p.y); };
  auto solve = [&](double cut) {
    cv::Matx33d A = cv::Matx33d::zeros();
    cv::Vec3d b(0, 0, 0);
    int n = 0;
    for (const cv::Point3f& p : pts) {
      if (cut > 0 && residual(p) > cut) continue;
      const cv::Vec3d x(1.0, p.x, p.y);
      A += x * x.t(), b += p.z * x, ++n;
    }
    cv::Vec3d sol;
    if (n < 10 || !cv::solve(A, b, sol, cv::DECOMP_CHOLESKY)) return false;
    c[0] = sol[0], c[1] = sol[1], c[2] = sol[2];
    return true;
  };
  auto shallow_sigma = [&] {  // 1.4826 · median |r| over r ≤ 0
    std::vector<double> res;
    for (const cv::Point3f& p : pts)
      if (const double r = residual(p); r <= 0) res.push_back(-r);
    return res.size() < 10 ? 0.0 : RobustSigmaOfAbs(res);
  };
  if (!solve(0)) return false;
  for (int it = 0; it < 3; ++it) {
    const double s = shallow_sigma();
    if (!(s > 0) || !solve(3 * s)) break;
  }
  *sigma = shallow_sigma();
  return true;
}

// Mean depth (above the ring plane) of the one-pixel rings about a depression's outline: x = the
// ring centre's distance inside the outline's outer edge (negative outside), m = its mean depth.
struct RimProfile {
  std::vector<double> x, m;
};

// Distance (px) from the outer edge of a depression's outline to where its wall meets the road
// (the support of its depth), from its ring profile (rings outside: the road; inside: the wall's
// outer part). Model: m(x) = c + a·max(0, x + gap)^p, c the road's level just outside (the ring
// plane 1-2 bands out misses the local road model's misfit there, which would move a
// tangential wall's extrapolated edge), p = 1 for a wall meeting the road at an angle (a
// sharp edge), p = 2 for one leaving it tangentially (a rounded edge: any smooth bowl, the
// simulator's smoothstep wall). p in [1, 2] (steps of 0.1) and gap in [0, max_gap] (steps of
// 0.05 px) on a grid, c and a by least squares; the best fit's gap. With p fixed at 1 and c at 0
// a tangential wall would keep half its gap; three inner rings alone would let their noise
// decide p (a second difference).
double OpeningEdgeGapPx(const RimProfile& r, double max_gap) {
  const int n = static_cast<int>(r.x.size());
  if (n < 3) return 0;
  constexpr double kStep = 0.05;
  double best_cost = INFINITY, best_gap = 0;
  std::vector<double> phi(n);
  const int steps = static_cast<int>(std::floor(max_gap / kStep));
  // x + gap lies on the grid (x at half pixels): the power law tabulated once per p.
  std::vector<int> xi(n);
  int top = 0;
  for (int j = 0; j < n; ++j) xi[j] = static_cast<int>(std::lround(r.x[j] / kStep)), top = std::max(top, xi[j]);
  std::vector<double> power(top + steps + 1);
  for (int pk = 0; pk <= 10; ++pk) {
    const double p = 1 + 0.1 * pk;
    for (size_t k = 0; k < power.size(); ++k) power[k] = std::pow(k * kStep, p);
    for (int gk = 0; gk <= steps; ++gk) {
      const double gap = gk * kStep;
      double s1 = 0, sp = 0, spp = 0, sm = 0, spm = 0;
      for (int j = 0; j < n; ++j) {
        phi[j] = xi[j] + gk > 0 ? power[xi[j] + gk] : 0.0;
        s1 += 1, sp += phi[j], spp += phi[j] * phi[j], sm += r.m[j], spm += phi[j] * r.m[j];
      }
      const double det = s1 * spp - sp * sp;
      if (!(det > 0)) continue;
      const double a = (s1 * spm - sp * sm) / det, c = (sm - a * sp) / s1;
      if (!(a > 0)) continue;
      double cost = 0;
      for (int j = 0; j < n; ++j) {
        const double e = r.m[j] - c - a * phi[j];
        cost += e * e;
      }
      if (cost < best_cost) best_cost = cost, best_gap = gap;
    }
  }
  return best_gap;
}

// Rings about an outline: at most this many inside and outside.
constexpr int kMaxRings = 12;

// Per ring, the sum and count of depths above the ring plane: inside (j = 0 the outermost) and
// outside (k = 0 the nearest).
struct RingSums {
  double sum_in[kMaxRings] = {0}, sum_out[kMaxRings] = {0};
  int n_in[kMaxRings] = {0}, n_out[kMaxRings] = {0};
  void operator+=(const RingSums& o) {
    for (int j = 0; j < kMaxRings; ++j)
      sum_in[j] += o.sum_in[j], sum_out[j] += o.sum_out[j], n_in[j] += o.n_in[j], n_out[j] += o.n_out[j];
  }
};

// The two outer inner rings stand 4 σ of a mean clear of the road and of each other (unbounded
// steps would grow potholes on noisy slopes): σ of a mean of n pixels of a
// relief smoothed over w × w is σ·w/√n.
bool WallSignificant(const RingSums& s, double ring_sigma, int window_px) {
  if (s.n_in[0] < 10 || s.n_in[1] < 10) return false;
  const double m1 = s.sum_in[0] / s.n_in[0], m2 = s.sum_in[1] / s.n_in[1];
  const double sigma_m =
      ring_sigma * std::max(1, window_px) / std::sqrt(static_cast<double>(std::min(s.n_in[0], s.n_in[1])));
  return m1 >= 4 * sigma_m && m2 - m1 >= 4 * sigma_m;
}

// The ring means as a profile for OpeningEdgeGapPx: inside while within the wall's outer quarter
// (at least four rings: a bowl's wall bends over towards the floor, where the power law no longer
// holds), outside up to kMaxRings; rings with fewer than 10 pixels end either side. Empty when
// fewer than four inner rings.
RimProfile WallProfile(const RingSums& s, double depth99_mm) {
  RimProfile prof;
  for (int j = 0; j < kMaxRings && s.n_in[j] >= 10; ++j) {
    const double mj = s.sum_in[j] / s.n_in[j];
    if (j >= 4 && mj > 0.25 * depth99_mm) break;
    prof.x.push_back(j + 0.5), prof.m.push_back(mj);
  }
  if (prof.x.size() < 4) return {};
  for (int k = 0; k < kMaxRings && s.n_out[k] >= 10; ++k)
    prof.x.push_back(-(k + 0.5)), prof.m.push_back(s.sum_out[k] / s.n_out[k]);
  return prof;
}

// The depth plane of the ring around an instance (mm), in roi coordinates about its centre.
struct RingPlane {
  double c[3] = {0, 0, 0};
  int cu = 0, cv = 0;
  double operator()(int u, int v) const { return c[0] + c[1] * (u - cu) + c[2] * (v - cv); }
};

// One side of an outline along image scanlines (oblique views): columns scanned from the top
// (dir = +1) or the bottom (-1), rows from the left (+1) or the right (-1). Per scanline the first
// instance pixel is the edge; ring j inside is j pixels in from it, ring k outside k + 1 pixels out
// (road only: no instance, obstacle, nothing beyond two bands). Only the scanlines where the outline
// runs within 45° of across them on the road are this side's: its slope over ±w scanlines, rows
// counting e column widths. Scanlines whose edge pixel is deeper than `max_edge_mm` (the wall's
// outer quarter) end at an occluding edge (the ray passed over the wall: the depth jumps there, the
// outline is exact) and are left out.
struct SideScan {
  RingSums sums;
  std::vector<cv::Point> edges;  ///< (scanline, its edge's coordinate along it)
};

SideScan ScanSide(const cv::Mat& lab, const cv::Mat& in0, const cv::Mat& rim_depth, const cv::Mat& obstacle,
                  const cv::Mat& dist, int band, const RingPlane& level, double e, bool columns, int dir,
                  double max_edge_mm) {
  const int lines = columns ? lab.cols : lab.rows, len = columns ? lab.rows : lab.cols;
  auto px = [&](int i, int t) { return columns ? cv::Point(i, t) : cv::Point(t, i); };
  std::vector<int> edge(lines, -1);
  for (int i = 0; i < lines; ++i)
    for (int s = 0; s < len; ++s)
      if (const int t = dir > 0 ? s : len - 1 - s; in0.at<uchar>(px(i, t))) {
        edge[i] = t;
        break;
      }
  // Along a column scan the edge moves by rows (e units each) per column; along a row scan by
  // columns per row (e units).
  const int w = columns ? static_cast<int>(std::ceil(e)) : 1;
  const double max_move = columns ? 2 * w / e : 2 * w * e;
  SideScan r;
  for (int i = w; i + w < lines; ++i) {
    if (edge[i] < 0 || edge[i - w] < 0 || edge[i + w] < 0 || std::abs(edge[i + w] - edge[i - w]) > max_move) continue;
    // An occluding edge: the outline's pixel already shows more than the wall's outer part.
    const cv::Point p0 = px(i, edge[i]);
    if (!(rim_depth.at<float>(p0) - level(p0.x, p0.y) <= max_edge_mm)) continue;
    r.edges.emplace_back(i, edge[i]);
    for (int j = 0; j < kMaxRings; ++j) {
      const int t = edge[i] + dir * j;
      if (t < 0 || t >= len || !in0.at<uchar>(px(i, t))) break;
      const cv::Point p = px(i, t);
      if (const float x = rim_depth.at<float>(p); std::isfinite(x))
        r.sums.sum_in[j] += x - level(p.x, p.y), ++r.sums.n_in[j];
    }
    for (int k = 0; k < kMaxRings; ++k) {
      const int t = edge[i] - dir * (k + 1);
      if (t < 0 || t >= len) break;
      const cv::Point p = px(i, t);
      if (lab.at<uint16_t>(p) != 0 || obstacle.at<uchar>(p) || dist.at<float>(p) > 2 * band) break;
      if (const float x = rim_depth.at<float>(p); std::isfinite(x))
        r.sums.sum_out[k] += x - level(p.x, p.y), ++r.sums.n_out[k];
    }
  }
  return r;
}

// Adds `gap` pixels (fractional: error diffusion along the side, so the area added is gap per
// scanline on average; the true edge's phase on the pixel grid is unknown) beyond each edge of a
// side, road pixels only.
void GrowSide(cv::Mat& lab, int id, const cv::Mat& obstacle, const SideScan& side, bool columns, int dir, double gap) {
  const int len = columns ? lab.rows : lab.cols;
  double acc = 0.5;
  for (const cv::Point& ed : side.edges) {
    acc += gap;
    const int n = static_cast<int>(std::floor(acc));
    acc -= n;
    for (int k = 1; k <= n; ++k) {
      const int t = ed.y - dir * k;
      if (t < 0 || t >= len) break;
      const cv::Point p = columns ? cv::Point(ed.x, t) : cv::Point(t, ed.x);
      uint16_t& l = lab.at<uint16_t>(p);
      if ((l != 0 && l != id) || obstacle.at<uchar>(p)) break;
      l = static_cast<uint16_t>(id);
    }
  }
}

// Oblique views (e >= kObliqueElongation): the opening's edge side by side, in image scanlines across each side.
// The near rim is an occluding edge: a ray crossing the road just inside it passes over the wall
// (a wall leaving the road tangentially is steeper than a ray at 15-20° within a millimetre or
// two of the rim) onto the floor or the far wall, so the depth jumps there and the outline is
// already exact; a profile across it is no wall's (rings all round, dilated by whole pixels,
// would grow them: rows are several times longer on the road than columns). A side wall is
// seen about as from above (its ray meets it near where it crosses the road). The far wall faces
// the camera, but a pixel's depth is that of the point its ray meets after crossing the road, at
// most tanθ × the run below the road, so the far outline stops about T / tanθ farther inside than
// the wall's own gap at threshold T: its profile in rows is still fitted well enough by the power
// law (between the tangential start and the linear t·s of the run). The far side is fitted along
// columns (gap in rows), the near side the same on its scanlines that end at no occluding edge (a
// wide shallow pothole's near wall, gentler than the ray, is seen), the two lateral sides pooled
// along rows (gap in columns). `sigma_mm`: the ring's per-pixel noise (WallSignificant).
void ExtendObliqueSides(cv::Mat& lab, int id, const cv::Mat& in0, const cv::Mat& rim_depth, const cv::Mat& obstacle,
                        const cv::Mat& dist, int band, const RingPlane& level, double sigma_mm, int window_px,
                        double depth99_mm, double e, bool far_up) {
  const int far_dir = far_up ? 1 : -1;
  const double max_edge_mm = 0.25 * depth99_mm;
  auto scan = [&](bool columns, int dir, double max_edge) {
    return ScanSide(lab, in0, rim_depth, obstacle, dist, band, level, e, columns, dir, max_edge);
  };
  const SideScan far = scan(true, far_dir, INFINITY), near = scan(true, -far_dir, max_edge_mm);
  const SideScan left = scan(false, 1, INFINITY), right = scan(false, -1, INFINITY);
  RingSums lateral = left.sums;
  lateral += right.sums;
  auto gap_of = [&](const RingSums& s, double cap) {
    if (!WallSignificant(s, sigma_mm, window_px)) return 0.0;
    const RimProfile prof = WallProfile(s, depth99_mm);
    return prof.x.empty() ? 0.0 : std::min(cap, OpeningEdgeGapPx(prof, cap + 0.5));
  };
  // At most a quarter of the band on the road (at least 2 px), as near nadir.
  const double cap_rows = std::max(2.0, band / (4.0 * e)), cap_cols = std::max(2, band / 4);
  const double g_far = gap_of(far.sums, cap_rows), g_near = gap_of(near.sums, cap_rows);
  const double g_lat = gap_of(lateral, cap_cols);
  GrowSide(lab, id, obstacle, far, true, far_dir, g_far);
  GrowSide(lab, id, obstacle, near, true, -far_dir, g_near);
  GrowSide(lab, id, obstacle, left, false, 1, g_lat);
  GrowSide(lab, id, obstacle, right, false, -1, g_lat);
}

// One instance's working set for the rim extension: the instance's box padded by its band
// (views into the labels: writes go to them) and the depths the rim is found on.
struct RimWindow {
  int id = 0;
  double e = 1;   // row elongation at the box's centre (≥ 1)
  int k = 1;      // rows per road unit (e rounded)
  int band = 1;   // how far the rim may lie outside the instance, px
  cv::Rect box;   // the instance's bounding box as segmented, in the frame
  cv::Mat lab;    // the labels over the window (a view)
  cv::Mat inst;   // the instance as segmented
  cv::Mat depth;  // depth below the road, mm
  cv::Mat obstacle;
  cv::Mat rim_depth;  // the depth the rim is found on
  cv::Mat dist;       // outside: distance to the instance (road units)
  cv::Rect box_in;    // the instance's box + 1 px, in the window
  cv::Mat depth_in;   // inside (over box_in): distance to the outside
};

RimWindow OpenRimWindow(cv::Mat& labels, int id, const cv::Rect& box, const RoadRelief& r,
                        const std::vector<double>& row_elongation, const cv::Mat& raw_depth_below_mm) {
  RimWindow w;
  w.id = id, w.box = box;
  // Distances on the road, in units of a column's width: an oblique view's rows are e times
  // longer on the road, so a band of whole pixels would reach e times farther along the view
  // than across (and stop short of a foreshortened pothole's cut-off ends).
  const int centre = box.y + box.height / 2;
  const double e = centre < static_cast<int>(row_elongation.size()) ? std::max(1.0, row_elongation[centre]) : 1.0;
  const int k = std::max(1, static_cast<int>(std::lround(e)));
  const int count = cv::countNonZero(labels(box) == id);
  const int band = std::max(1, static_cast<int>(0.3 * std::sqrt(count * k / CV_PI)));
  const int pad_u = 2 * band + 1, pad_v = 2 * band / k + 1;
  const cv::Rect roi = cv::Rect(box.x - pad_u, box.y - pad_v, box.width + 2 * pad_u, box.height + 2 * pad_v) &
                       cv::Rect({}, labels.size());
  w.e = e, w.k = k, w.band = band;
  w.lab = labels(roi);  // view: writes go to `labels`
  w.inst = w.lab == id;
  w.depth = r.depth_below_mm(roi), w.obstacle = r.obstacle_mask(roi);
  // The rim is found on the unsmoothed depth where given: the relief's box filter spreads a
  // wall's depth up to half its window onto the road beyond the rim (a halo that grows with the
  // depth), so on the smoothed relief a threshold low enough to reach the rim of a gently
  // starting wall also grows steep ones into the road.
  w.rim_depth = w.depth;
  if (!raw_depth_below_mm.empty()) {
    w.rim_depth = raw_depth_below_mm(roi).clone();
    if (!r.correction_mm.empty()) w.rim_depth -= r.correction_mm(roi);
  }
  w.dist = RoadDistance(w.inst == 0, k);  // outside: distance to the instance
  // Inside: distance to the outside, over the instance's box only (a quarter of the roi's area).
  w.box_in = cv::Rect(box.x - roi.x - 1, box.y - roi.y - 1, box.width + 2, box.height + 2) & cv::Rect({}, w.lab.size());
  w.depth_in = RoadDistance(w.inst(w.box_in), k);
  return w;
}

// The road's level around an instance and the thresholds the rim is found with.
struct RimLevel {
  std::vector<cv::Point3f> ring;  // ring pixels (centred coordinates, depth)
  RingPlane level;
  double floor_mm = 0;     // the rim threshold's floor: rim_depth_m, or the fraction of the depth
  double depth99_mm = 0;   // the instance's 99th-percentile depth
  double ring_sigma = 0;   // the ring's spread about its plane (smoothed depth)
  double pixel_sigma = 0;  // the same on the rim depth, per pixel
  double noise_mm = 0;     // per-pixel threshold above the level
};

// The road around the instance, a ring one to two bands outside, as a plane: its level is the
// local road model's misfit there (a crown's ridge, a verge rising beside the lane), its spread
// the stereo noise. A plane, not one level: beside a verge the road rises across a pothole.
RimLevel FitRimLevel(const RimWindow& w, double rim_depth_m, double rim_depth_fraction) {
  const cv::Mat &lab = w.lab, &inst = w.inst, &depth = w.depth, &obstacle = w.obstacle, &dist = w.dist;
  const cv::Mat& rim_depth = w.rim_depth;
  const int band = w.band;
  RimLevel out;
  std::vector<cv::Point3f>& ring = out.ring;
  std::vector<float> ring_raw;  // the rim depth at the same pixels
  for (int v = 0; v < lab.rows; ++v) {
    const float* dr = dist.ptr<float>(v);
    const float* xr = depth.ptr<float>(v);
    const uint16_t* lr = lab.ptr<uint16_t>(v);
    const uchar* obr = obstacle.ptr<uchar>(v);
    for (int u = 0; u < lab.cols; ++u) {
      const float dd = dr[u], x = xr[u];
      if (dd > band && dd <= 2 * band && lr[u] == 0 && !obr[u] && std::isfinite(x)) {
        ring.emplace_back(static_cast<float>(u - lab.cols / 2), static_cast<float>(v - lab.rows / 2), x);
        ring_raw.push_back(rim_depth.at<float>(v, u));
      }
    }
  }
  // The instance's depth (99th percentile): the smoothing's halo and the local model's misfit
  // beside a deep wall grow with it.
  std::vector<float> inside;
  for (int v = 0; v < lab.rows; ++v) {
    const uchar* in = inst.ptr<uchar>(v);
    const float* xr = depth.ptr<float>(v);
    for (int u = 0; u < lab.cols; ++u)
      if (in[u] && std::isfinite(xr[u])) inside.push_back(xr[u]);
  }
  double floor_mm = rim_depth_m * 1000.0, plane[3] = {0, 0, 0}, ring_sigma = 0, depth99_mm = 0;
  if (!inside.empty()) {
    depth99_mm = KthSmallestInPlace(inside, QuantileRankDown(0.99, inside.size()));
    floor_mm = std::max(floor_mm, rim_depth_fraction * depth99_mm);
  }
  if (ring.size() < 20 || !FitDepthPlane(ring, plane, &ring_sigma)) plane[0] = plane[1] = plane[2] = 0, ring_sigma = 0;
  out.level = RingPlane{{plane[0], plane[1], plane[2]}, lab.cols / 2, lab.rows / 2};
  // Per pixel the rim depth's own noise about the plane (unsmoothed: about w times the relief's).
  double pixel_sigma = ring_sigma;
  if (rim_depth.data != depth.data && ring_sigma > 0) {
    std::vector<float> res;
    for (size_t i = 0; i < ring.size(); ++i)
      if (std::isfinite(ring_raw[i]))
        res.push_back(
            std::abs(ring_raw[i] - static_cast<float>(plane[0] + plane[1] * ring[i].x + plane[2] * ring[i].y)));
    if (res.size() >= 20) pixel_sigma = RobustSigmaOfAbs(res);
  }
  out.floor_mm = floor_mm, out.depth99_mm = depth99_mm, out.ring_sigma = ring_sigma, out.pixel_sigma = pixel_sigma;
  out.noise_mm = std::max(floor_mm, 3.0 * pixel_sigma);  // per pixel: above the noise too
  return out;
}

// The outline follows the depth, not the segmentation's superpixels: the instance's outer pixels
// no deeper than the per-pixel threshold (connected to the outside through such pixels, within
// the band) are dropped; a superpixel straddling the rim joins on a vote and takes road with it.
void DropShallowOuterPixels(RimWindow& w, const RimLevel& lv) {
  cv::Mat& lab = w.lab;
  const cv::Mat &inst = w.inst, &rim_depth = w.rim_depth, &depth_in = w.depth_in;
  const cv::Rect& box_in = w.box_in;
  const RingPlane& level = lv.level;
  cv::Mat shallow(lab.size(), CV_8U, cv::Scalar(0));
  for (int v = box_in.y; v < box_in.y + box_in.height; ++v) {
    const uchar* in = inst.ptr<uchar>(v);
    const float* xr = rim_depth.ptr<float>(v);
    const float* di = depth_in.ptr<float>(v - box_in.y) - box_in.x;
    uchar* sh = shallow.ptr<uchar>(v);
    for (int u = box_in.x; u < box_in.x + box_in.width; ++u)
      if (in[u] && di[u] <= w.band && xr[u] < level(u, v) + lv.noise_mm) sh[u] = 255;  // NaN compares false
  }
  if (cv::countNonZero(shallow) == 0) return;
  cv::Mat cc;
  const int n = cv::connectedComponents(shallow, cc, 8, CV_32S);
  std::vector<char> outer(n, 0);
  for (int v = 0; v < lab.rows; ++v) {
    const int* c = cc.ptr<int>(v);
    for (int u = 0; u < lab.cols; ++u) {
      if (c[u] == 0 || outer[c[u]]) continue;
      // 4-neighbour outside the instance (or the roi's edge).
      const bool edge = u == 0 || v == 0 || u + 1 == lab.cols || v + 1 == lab.rows;
      if (edge || !inst.at<uchar>(v, u - 1) || !inst.at<uchar>(v, u + 1) || !inst.at<uchar>(v - 1, u) ||
          !inst.at<uchar>(v + 1, u))
        outer[c[u]] = 1;
    }
  }
  int kept = 0;
  for (int v = 0; v < lab.rows; ++v) {
    const int* c = cc.ptr<int>(v);
    const uchar* in = inst.ptr<uchar>(v);
    for (int u = 0; u < lab.cols; ++u) kept += in[u] && !(c[u] > 0 && outer[c[u]]);
  }
  if (kept == 0) return;  // an instance shallow throughout keeps its segmentation
  for (int v = 0; v < lab.rows; ++v) {
    const int* c = cc.ptr<int>(v);
    uint16_t* l = lab.ptr<uint16_t>(v);
    for (int u = 0; u < lab.cols; ++u)
      if (c[u] > 0 && outer[c[u]]) l[u] = 0;
  }
}

// Candidates: deep (NaN compares false), inside the band, not another instance; those connected
// to the instance join it.
void GrowDeepPixels(RimWindow& w, const RimLevel& lv) {
  cv::Mat& lab = w.lab;
  const cv::Mat &dist = w.dist, &rim_depth = w.rim_depth;
  const RingPlane& level = lv.level;
  const int id = w.id;
  const cv::Mat core = lab == id;
  cv::Mat cand(lab.size(), CV_8U, cv::Scalar(0));
  for (int v = 0; v < lab.rows; ++v) {
    const float* dr = dist.ptr<float>(v);
    const float* xr = rim_depth.ptr<float>(v);
    const uint16_t* lr = lab.ptr<uint16_t>(v);
    const uchar* co = core.ptr<uchar>(v);
    uchar* ca = cand.ptr<uchar>(v);
    for (int u = 0; u < lab.cols; ++u)
      if (co[u] || (lr[u] == 0 && dr[u] <= w.band && xr[u] >= level(u, v) + lv.noise_mm)) ca[u] = 255;
  }
  cv::Mat cc;
  const int n = cv::connectedComponents(cand, cc, 8, CV_32S);
  std::vector<char> keep(n, 0);
  for (int v = 0; v < cc.rows; ++v) {
    const uchar* in = core.ptr<uchar>(v);
    const int* c = cc.ptr<int>(v);
    for (int u = 0; u < cc.cols; ++u)
      if (in[u]) keep[c[u]] = 1;
  }
  for (int v = 0; v < cc.rows; ++v) {
    uint16_t* l = lab.ptr<uint16_t>(v);
    const int* c = cc.ptr<int>(v);
    for (int u = 0; u < cc.cols; ++u)
      if (c[u] > 0 && keep[c[u]] && l[u] == 0) l[u] = static_cast<uint16_t>(id);
  }
}

// Beyond the per-pixel threshold, whole one-pixel rings join while their mean depth above the
// ring's plane stands significantly (2 σ of a mean) above the road: n pixels of a relief
// smoothed over w×w are about n / w² independent samples, so the mean's noise is σ·w/√n and the
// wall's shallow outer part, lost in the per-pixel noise, is still found.
void GrowSignificantRings(RimWindow& w, const RimLevel& lv, int ring_window_px) {
  cv::Mat& lab = w.lab;
  const cv::Mat &dist = w.dist, &rim_depth = w.rim_depth, &obstacle = w.obstacle;
  const RingPlane& level = lv.level;
  const int id = w.id, band = w.band;
  const cv::Mat grown_dist = RoadDistance(lab != id, w.k);
  std::vector<double> sum(band + 2, 0.0);
  std::vector<int> cnt(band + 2, 0);
  for (int v = 0; v < lab.rows; ++v) {
    const float* gd = grown_dist.ptr<float>(v);
    const float* od = dist.ptr<float>(v);
    const float* x = rim_depth.ptr<float>(v);
    const uint16_t* l = lab.ptr<uint16_t>(v);
    const uchar* ob = obstacle.ptr<uchar>(v);
    for (int u = 0; u < lab.cols; ++u) {
      if (gd[u] <= 0 || gd[u] > band || od[u] > band || l[u] != 0 || ob[u] || !std::isfinite(x[u])) continue;
      const int ring_k = static_cast<int>(std::ceil(gd[u]));
      sum[ring_k] += x[u] - level(u, v), ++cnt[ring_k];
    }
  }
  int rings = 0;
  for (int j = 1; j <= band; ++j) {
    if (cnt[j] < 10) break;
    const double sigma_mean = lv.ring_sigma * ring_window_px / std::sqrt(static_cast<double>(cnt[j]));
    if (sum[j] / cnt[j] < std::max(lv.floor_mm, 2.0 * sigma_mean)) break;
    rings = j;
  }
  for (int v = 0; v < lab.rows && rings > 0; ++v) {
    uint16_t* l = lab.ptr<uint16_t>(v);
    const float* gd = grown_dist.ptr<float>(v);
    const float* od = dist.ptr<float>(v);
    const uchar* ob = obstacle.ptr<uchar>(v);
    for (int u = 0; u < lab.cols; ++u)
      if (gd[u] > 0 && gd[u] <= rings && od[u] <= band && l[u] == 0 && !ob[u]) l[u] = static_cast<uint16_t>(id);
  }
}

// Oblique views: each side extended as the view shows it (ExtendObliqueSides), where the
// matcher's noise does not set the threshold (there nothing is added). The matcher's noise from
// differences of ring pixels a smoothing window apart along the row: in a car view the ring
// plane's residual is mostly the road's own shape over a ring metres long, not noise; the lag
// keeps a disparity's noise, correlated over the matcher's window, whole.
void ExtendObliqueOpening(RimWindow& w, const RimLevel& lv, const cv::Mat& in0, int ring_window_px, bool far_up) {
  cv::Mat& lab = w.lab;
  const cv::Mat &rim_depth = w.rim_depth, &obstacle = w.obstacle;
  const int lag = std::max(1, ring_window_px) + 1;
  std::vector<float> diff;
  for (const cv::Point3f& q : lv.ring) {
    const int u = static_cast<int>(q.x) + lab.cols / 2, v = static_cast<int>(q.y) + lab.rows / 2;
    if (u + lag >= lab.cols || lab.at<uint16_t>(v, u + lag) != 0 || obstacle.at<uchar>(v, u + lag)) continue;
    if (const float d = rim_depth.at<float>(v, u + lag) - rim_depth.at<float>(v, u); std::isfinite(d))
      diff.push_back(std::abs(d));
  }
  double pair_sigma = lv.pixel_sigma;
  if (diff.size() >= 20) pair_sigma = RobustSigmaOfAbs(diff) / std::sqrt(2.0);
  if (3 * pair_sigma < lv.floor_mm)
    ExtendObliqueSides(lab, w.id, in0, rim_depth, obstacle, w.dist, w.band, lv.level, pair_sigma, ring_window_px,
                       lv.depth99_mm, w.e, far_up);
}

// Near nadir: rings at 4-neighbour (city-block) distance to the outline, the metric of the
// cross dilation that adds rings. Inside up to kMaxRings px, while their mean depth stays within
// the wall's outer quarter (WallProfile); outside up to kMaxRings px (within two bands of the
// segmented instance; road only: no other instance, obstacle). Where the per-pixel noise sets
// the rim threshold, the profile's shape near the outline is the disparity's smoothing, not the
// wall's: there the first-order step stays (the outline's two inner rings, at most 2 px out).
void ExtendNadirOpening(RimWindow& w, const RimLevel& lv, const cv::Mat& in0, int ring_window_px) {
  cv::Mat& lab = w.lab;
  const cv::Mat &dist = w.dist, &rim_depth = w.rim_depth, &obstacle = w.obstacle;
  const RingPlane& level = lv.level;
  const int id = w.id, band = w.band;
  const bool fit_profile = 3 * lv.pixel_sigma < lv.floor_mm;
  cv::Mat in_dist, out_dist;
  cv::distanceTransform(in0, in_dist, cv::DIST_L1, 3);
  if (fit_profile) cv::distanceTransform(in0 == 0, out_dist, cv::DIST_L1, 3);
  RingSums rings_sum;
  for (int v = 0; v < lab.rows; ++v) {
    const float* di = in_dist.ptr<float>(v);
    const float* dout = fit_profile ? out_dist.ptr<float>(v) : nullptr;
    const float* od = dist.ptr<float>(v);
    const float* x = rim_depth.ptr<float>(v);
    const uint16_t* l = lab.ptr<uint16_t>(v);
    const uchar* ob = obstacle.ptr<uchar>(v);
    for (int u = 0; u < lab.cols; ++u) {
      if (!std::isfinite(x[u])) continue;
      if (const int j = static_cast<int>(di[u]) - 1; j >= 0 && j < kMaxRings) {
        rings_sum.sum_in[j] += x[u] - level(u, v), ++rings_sum.n_in[j];
      } else if (const int k = dout ? static_cast<int>(dout[u]) - 1 : -1;
                 k >= 0 && k < kMaxRings && l[u] == 0 && !ob[u] && od[u] <= 2 * band) {
        rings_sum.sum_out[k] += x[u] - level(u, v), ++rings_sum.n_out[k];
      }
    }
  }
  if (!WallSignificant(rings_sum, lv.ring_sigma, ring_window_px)) return;
  int extra;
  if (!fit_profile) {
    const double m1 = rings_sum.sum_in[0] / rings_sum.n_in[0], m2 = rings_sum.sum_in[1] / rings_sum.n_in[1];
    extra = std::min(2, static_cast<int>(std::floor(m1 / (m2 - m1))));  // round(m1/slope - 1/2)
  } else {
    const RimProfile prof = WallProfile(rings_sum, lv.depth99_mm);
    if (prof.x.empty()) return;
    // Ring k outside (its centre k - 1/2 px beyond the outline) lies in the opening while k - 1/2 < gap.
    extra = std::min(std::max(2, band / 4), static_cast<int>(std::lround(OpeningEdgeGapPx(prof, band / 4 + 2.5))));
  }
  const cv::Mat cross = cv::getStructuringElement(cv::MORPH_CROSS, {3, 3});
  if (extra <= 0) return;
  cv::Mat grown;
  cv::dilate(in0, grown, cross, {-1, -1}, extra);  // the pixels within `extra` px (4-neighbour steps)
  for (int v = 0; v < lab.rows; ++v) {
    uint16_t* l = lab.ptr<uint16_t>(v);
    const uchar* g = grown.ptr<uchar>(v);
    const uchar* ob = obstacle.ptr<uchar>(v);
    for (int u = 0; u < lab.cols; ++u)
      if (g[u] && l[u] == 0 && !ob[u]) l[u] = static_cast<uint16_t>(id);
  }
}

}  // namespace

void ExtendToRim(cv::Mat& labels, const RoadRelief& r, double rim_depth_m, double rim_depth_fraction,
                 int ring_window_px, const std::vector<double>& row_elongation, const cv::Mat& raw_depth_below_mm) {
  // Boxes and pixel counts of the instances as segmented (growth of one id never changes another's).
  const std::vector<cv::Rect> boxes = LabelBoxes(labels);
  // The far side of an oblique view: where the rows are longer on the road.
  auto far_up = [&](const cv::Rect& b) {
    const int top = b.y, bottom = b.y + b.height - 1;
    return bottom >= static_cast<int>(row_elongation.size()) || row_elongation[top] >= row_elongation[bottom];
  };
  for (int id = 1; id < static_cast<int>(boxes.size()); ++id) {
    if (boxes[id].empty()) continue;
    RimWindow w = OpenRimWindow(labels, id, boxes[id], r, row_elongation, raw_depth_below_mm);
    const RimLevel lv = FitRimLevel(w, rim_depth_m, rim_depth_fraction);
    DropShallowOuterPixels(w, lv);
    GrowDeepPixels(w, lv);
    if (ring_window_px <= 0 || !(lv.ring_sigma > 0)) continue;
    GrowSignificantRings(w, lv, ring_window_px);
    // The opening's edge lies beyond the outline, which stops where the wall is still the
    // threshold deep: the wall's outer part, sampled on the outline's inner pixel rings, is
    // extended to the road's level just outside (OpeningEdgeGapPx: a power law between a wall
    // meeting the road at an angle and one leaving it tangentially). Only where the two outer
    // ring means stand 4 σ of a mean clear, by at most a quarter of the band (at least 2 px).
    // In oblique views a pixel's depth is not that of the surface where its ray crosses the
    // road: each side is extended as the view shows it.
    const cv::Mat in0 = w.lab == id;
    if (w.e >= kObliqueElongation)
      ExtendObliqueOpening(w, lv, in0, ring_window_px, far_up(boxes[id]));
    else
      ExtendNadirOpening(w, lv, in0, ring_window_px);
  }
}

double CoreWidthM(const cv::Mat& labels, int id, const RoadRelief& r, const cv::Mat& pixel_area_m2, double min_depth_m,
                  cv::Rect box, double* width_px) {
  if (width_px) *width_px = 0;
  cv::Rect roi = box.empty() ? cv::boundingRect(labels == id) : box;
  if (roi.empty()) return 0;
  roi = cv::Rect(roi.x - 1, roi.y - 1, roi.width + 2, roi.height + 2) & cv::Rect({}, labels.size());
  // NaN depth compares false: unmatched pixels are not part of the core.
  const cv::Mat core = (labels(roi) == id) & (r.depth_below_mm(roi) >= min_depth_m * 1000.0);
  cv::Mat padded, dist;
  cv::copyMakeBorder(core, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  cv::distanceTransform(padded, dist, cv::DIST_L2, cv::DIST_MASK_5);
  double best = 0, best_px = 0;
  for (int v = 0; v < core.rows; ++v) {
    const float* ar = pixel_area_m2.ptr<float>(roi.y + v) + roi.x;
    const float* dr = dist.ptr<float>(v + 1) + 1;
    for (int u = 0; u < core.cols; ++u) {
      const float a = ar[u], dpx = dr[u];
      if (dpx > 0 && std::isfinite(a) && 2.0 * dpx * std::sqrt(double(a)) > best)
        best = 2.0 * dpx * std::sqrt(double(a)), best_px = 2.0 * dpx;
    }
  }
  if (width_px) *width_px = best_px;
  return best;
}

namespace {

// The pothole noise rule at the depression's own scale (MeasureScaleNoise): the window is the
// square inscribed in its core (the half-max-depth part's largest circle, `core_px` wide), so
// the deepest window mean is the floor's depth; it must be at least kMinScaleWindowPx, twice
// the relief's own 7-px box and SGM's ~10-px wrong-winner patches, or the average adds little.
// The road's window means are taken up to two of the noise map's 96-px cells around the box
// (as TwoSidedReliefNoise's leave-one-out).
constexpr int kMinScaleWindowPx = 15;
constexpr int kScaleMarginPx = 192;

bool ConfirmedAtScale(const cv::Mat& depth_below_mm, const cv::Mat& road, const cv::Mat& labels, int id,
                      const cv::Rect& box, double core_px, const MeasureOptions& o) {
  int window = static_cast<int>(core_px / std::sqrt(2.0));
  window -= 1 - window % 2;  // odd: centred
  if (window < kMinScaleWindowPx) return false;
  const ScaleNoise sn =
      MeasureScaleNoise(depth_below_mm, road, labels, id, box, window, kScaleMarginPx, o.spike_quantile, 0.0);
  // NaN (too few road windows around it) compares false: not confirmed.
  return sn.depth_mm >= o.pothole_min_noise_sigma * sn.sigma_mm &&
         (o.pothole_min_spike_ratio <= 0 || sn.depth_mm >= o.pothole_min_spike_ratio * sn.spike_mm);
}

}  // namespace

std::vector<DamageInstance> MeasureDepressions(const cv::Mat& labels, const RoadRelief& r, const RectifiedStereo& g,
                                               const RoadSurface& s, const MeasureOptions& o, const cv::Mat& noise_px,
                                               const cv::Mat& volume_depth) {
  if (labels.type() != CV_16UC1 || labels.size() != r.depth_below_mm.size())
    throw std::invalid_argument("MeasureDepressions: labels must be CV_16U of the relief's size");
  if (!noise_px.empty() && (noise_px.type() != CV_32FC1 || noise_px.size() != labels.size()))
    throw std::invalid_argument("MeasureDepressions: noise_px must be CV_32F of the labels' size");
  if (!volume_depth.empty() && (volume_depth.type() != CV_32FC1 || volume_depth.size() != labels.size()))
    throw std::invalid_argument("MeasureDepressions: volume_depth_below_mm must be CV_32F of the labels' size");
  const double fb = g.f_px * g.baseline_m;
  const cv::Mat area = PixelAreaOnRoad(r, g, s);
  double maxv = 0;
  cv::minMaxLoc(labels, nullptr, &maxv);
  const int n = static_cast<int>(maxv);
  struct Acc {
    std::vector<double> depth;
    double area = 0, area_valid = 0, volume = 0, z = 0, noise_mm = 0;
    double boundary_area = 0;  // of the pixels with a 4-neighbour outside the region
    int pixels = 0, invalid = 0;
  };
  std::vector<Acc> acc(n + 1);
  for (int v = 0; v < labels.rows; ++v) {
    const uint16_t* l = labels.ptr<uint16_t>(v);
    const float* d = r.depth_below_mm.ptr<float>(v);
    const float* dv = volume_depth.empty() ? d : volume_depth.ptr<float>(v);
    const float* a = area.ptr<float>(v);
    const float* z = r.road_depth_m.ptr<float>(v);
    for (int u = 0; u < labels.cols; ++u) {
      if (!l[u] || !std::isfinite(a[u])) continue;
      Acc& c = acc[l[u]];
      ++c.pixels;
      c.area += a[u];
      if (IsBoundaryPixel(labels, u, v)) c.boundary_area += a[u];
      c.z += z[u];
      if (!noise_px.empty()) {
        // Disparity noise as depth below the surface: a point moved along its ray by
        // ΔZ = Z²·σ_d/(f·B) changes its height by ΔZ·|n·ray|.
        const double nr =
            std::abs(s.normal.x() * (u - g.cx_px) / g.f_px + s.normal.y() * (v - g.cy_px) / g.f_px + s.normal.z());
        c.noise_mm += 1000.0 * noise_px.at<float>(v, u) * double(z[u]) * z[u] / fb * nr;
      }
      if (std::isfinite(d[u])) {
        const double depth_m = d[u] / 1000.0;
        c.depth.push_back(depth_m);
        c.area_valid += a[u];
        // Material above the road is not missing volume.
        c.volume += std::max(0.0, (std::isfinite(dv[u]) ? dv[u] : d[u]) / 1000.0) * a[u];
      } else {
        ++c.invalid;
      }
    }
  }
  const std::vector<cv::Rect> boxes = LabelBoxes(labels);
  cv::Mat road;  // valid, not obstacle: made when the first instance needs the scale test
  std::vector<DamageInstance> out;
  for (int id = 1; id <= n; ++id) {
    Acc& c = acc[id];
    if (c.pixels == 0) continue;
    DamageInstance d;
    d.id = id;
    d.pixel_count = c.pixels;
    d.area_m2 = c.area;
    d.range_m = c.z / c.pixels;
    d.sigma_depth_m = StereoDepthSigma(d.range_m, o.sigma_disparity_px, g);
    if (!c.depth.empty()) {
      double sum = 0;
      for (double x : c.depth) sum += x;
      d.mean_depth_m = sum / c.depth.size();
      d.max_depth_m = KthSmallestInPlace(c.depth, QuantileRankDown(o.depth_percentile, c.depth.size()));
      d.volume_m3 = c.volume + std::max(0.0, d.mean_depth_m) * (c.area - c.area_valid);
    }
    d.equivalent_diameter_m = std::sqrt(4.0 * d.area_m2 / CV_PI);
    d.sigma_area_m2 = AreaSigmaM2(c.boundary_area, OutlineSigmaPx(d.max_depth_m, d.sigma_depth_m, o));
    d.sigma_volume_m3 = VolumeSigmaM3(d.area_m2, d.mean_depth_m, d.sigma_depth_m, d.sigma_area_m2, c.pixels, o);
    d.outline_px = OutlineOf(labels, id, boxes[id]);
    std::vector<Eigen::Vector3d> ring;
    for (const cv::Point& p : d.outline_px) {
      const double z = s.RayDepth(g, p.x, p.y);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d q = CameraPointAtDepth(g, p.x, p.y, z);
      ring.push_back(q);
      d.outline_cam_m.emplace_back(q.x(), q.y(), q.z());
    }
    double dmax = 0;
    for (size_t i = 0; i < ring.size(); ++i)
      for (size_t j = i + 1; j < ring.size(); ++j) dmax = std::max(dmax, (ring[i] - ring[j]).norm());
    d.max_diameter_m = dmax;
    const bool measurable = std::isfinite(d.max_depth_m) && d.max_depth_m >= o.pothole_min_depth_m &&
                            d.max_depth_m >= o.pothole_min_depth_sigma * d.sigma_depth_m;
    const bool compact = d.max_diameter_m > 0 &&
                         d.area_m2 >= o.pothole_min_compactness * CV_PI / 4 * d.max_diameter_m * d.max_diameter_m;
    double core_px = 0;
    const bool shaped =
        measurable && compact && d.equivalent_diameter_m >= o.pothole_min_diameter_m &&
        CoreWidthM(labels, id, r, area, 0.5 * d.max_depth_m, boxes[id], &core_px) >= o.pothole_min_core_width_m;
    bool confirmed = 1000.0 * d.max_depth_m >= o.pothole_min_noise_sigma * c.noise_mm / c.pixels;
    // Deeper than the noise at its own scale: a depression much wider than SGM's wrong-winner
    // patches is not one of them (scale_noise.h). Only where the per-pixel rule does not decide.
    if (shaped && !confirmed && !noise_px.empty()) {
      if (road.empty()) road = r.valid_mask & (r.obstacle_mask == 0);
      confirmed = ConfirmedAtScale(r.depth_below_mm, road, labels, id, boxes[id], core_px, o);
    }
    const bool wide = shaped && confirmed;
    d.type = wide ? DamageType::kPothole : DamageType::kOther;
    // Confidence: how far the mean depth stands above the stereo noise (a 3σ_Z depression ≈ 0.99).
    d.confidence = std::isfinite(d.mean_depth_m) && d.sigma_depth_m > 0
                       ? 1.0 - std::exp(-0.5 * std::pow(std::max(0.0, d.mean_depth_m) / d.sigma_depth_m, 2))
                       : 0.0;
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace rs
