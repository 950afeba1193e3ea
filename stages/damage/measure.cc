#include "stages/damage/measure.h"

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>

namespace rs {

double StereoDepthSigma(double z_m, double sigma_d, const StereoGeometry& g) {
  return z_m * z_m * sigma_d / (g.f_px * g.baseline_m);
}

cv::Mat PixelAreaOnRoad(const RoadRelief& r, const StereoGeometry& g, const RoadSurface& s) {
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
  struct Box { int u0 = INT_MAX, v0 = INT_MAX, u1 = -1, v1 = -1; };
  // Bands of rows in parallel, merged afterwards (min/max: the same boxes for any split).
  constexpr int kBands = 8;
  std::vector<std::vector<Box>> band(kBands, std::vector<Box>(1));
  tbb::parallel_for(0, kBands, [&](int k) {
    std::vector<Box>& b = band[k];
    const int v0 = labels.rows * k / kBands, v1 = labels.rows * (k + 1) / kBands;
    for (int v = v0; v < v1; ++v) {
      const uint16_t* l = labels.ptr<uint16_t>(v);
      for (int u = 0; u < labels.cols; ++u) {
        const int id = l[u];
        if (!id) continue;
        if (id >= static_cast<int>(b.size())) b.resize(id + 1);
        Box& x = b[id];
        x.u0 = std::min(x.u0, u), x.u1 = std::max(x.u1, u), x.v0 = std::min(x.v0, v), x.v1 = std::max(x.v1, v);
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
  auto biggest = std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
    return cv::contourArea(a) < cv::contourArea(b);
  });
  std::vector<cv::Point> poly;
  cv::approxPolyDP(*biggest, poly, 1.0, true);
  return poly;
}

void ExtendToRim(cv::Mat& labels, const RoadRelief& r, double rim_depth_m, double rim_depth_fraction,
                 int ring_window_px) {
  // Boxes and pixel counts of the instances as segmented (growth of one id never changes another's).
  const std::vector<cv::Rect> boxes = LabelBoxes(labels);
  for (int id = 1; id < static_cast<int>(boxes.size()); ++id) {
    if (boxes[id].empty()) continue;
    const int count = cv::countNonZero(labels(boxes[id]) == id);
    const int band = std::max(1, static_cast<int>(0.3 * std::sqrt(count / CV_PI)));
    const int pad = 2 * band + 1;
    const cv::Rect roi = cv::Rect(boxes[id].x - pad, boxes[id].y - pad, boxes[id].width + 2 * pad,
                                  boxes[id].height + 2 * pad) &
                         cv::Rect({}, labels.size());
    cv::Mat lab = labels(roi);  // view: writes go to `labels`
    const cv::Mat inst = lab == id;
    const cv::Mat depth = r.depth_below_mm(roi), obstacle = r.obstacle_mask(roi);
    cv::Mat dist;  // distance to the instance, px
    cv::distanceTransform(inst == 0, dist, cv::DIST_L2, cv::DIST_MASK_5);
    // Level and spread of the road in a ring just outside the band: the rim threshold must stand
    // above the local road-model misfit (a crown's ridge) and the stereo noise, else the rim
    // grows into the road.
    std::vector<float> ring;
    for (int v = 0; v < lab.rows; ++v) {
      const float* dr = dist.ptr<float>(v);
      const float* xr = depth.ptr<float>(v);
      const uint16_t* lr = lab.ptr<uint16_t>(v);
      const uchar* obr = obstacle.ptr<uchar>(v);
      for (int u = 0; u < lab.cols; ++u) {
        const float dd = dr[u], x = xr[u];
        if (dd > band && dd <= 2 * band && lr[u] == 0 && !obr[u] && std::isfinite(x)) ring.push_back(x);
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
    double threshold_mm = rim_depth_m * 1000.0, ring_level = 0, ring_sigma = 0;
    if (!inside.empty()) {
      auto at = inside.begin() + static_cast<long>(0.99 * (inside.size() - 1));
      std::nth_element(inside.begin(), at, inside.end());
      threshold_mm = std::max(threshold_mm, rim_depth_fraction * *at);
    }
    if (ring.size() >= 20) {
      auto mid = ring.begin() + ring.size() / 2;
      std::nth_element(ring.begin(), mid, ring.end());
      const double level = *mid;
      for (float& x : ring) x = std::abs(x - static_cast<float>(level));
      std::nth_element(ring.begin(), mid, ring.end());
      ring_level = level, ring_sigma = 1.4826 * *mid;
    }
    // Counted from the ring's level: where the local road model sits 1-2 mm off beside the
    // instance (car view: the correction interpolated across the excluded damage), a rim
    // threshold of a few mm above zero grew a 0.5 m² pothole by 60 % into that plateau.
    const double level_mm = std::max(0.0, ring_level);
    const double floor_mm = level_mm + threshold_mm;  // without the ring's noise term
    threshold_mm = level_mm + std::max(threshold_mm, 3.0 * ring_sigma);
    // Candidates: deep (NaN compares false), inside the band, not another instance; keep those
    // connected to the instance.
    const cv::Mat cand = ((depth >= threshold_mm) & (dist <= band) & (lab == 0)) | inst;
    cv::Mat cc;
    const int n = cv::connectedComponents(cand, cc, 8, CV_32S);
    std::vector<char> keep(n, 0);
    for (int v = 0; v < cc.rows; ++v) {
      const uchar* in = inst.ptr<uchar>(v);
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
    if (ring_window_px <= 0 || !(ring_sigma > 0)) continue;
    // Beyond the per-pixel threshold, whole one-pixel rings join while their mean depth stands
    // significantly (2 σ of a mean) above the road: n pixels of a relief smoothed over w×w are
    // about n / w² independent samples, so the mean's noise is σ·w/√n and the wall's shallow
    // outer part, lost in the per-pixel noise, is still found (with noisy disparity the
    // per-pixel rim stopped 5-6 px short: area -10 to -18 %).
    cv::Mat grown_dist;
    cv::distanceTransform(lab != id, grown_dist, cv::DIST_L2, cv::DIST_MASK_5);
    std::vector<double> sum(band + 2, 0.0);
    std::vector<int> cnt(band + 2, 0);
    for (int v = 0; v < lab.rows; ++v) {
      const float* gd = grown_dist.ptr<float>(v);
      const float* od = dist.ptr<float>(v);
      const float* x = depth.ptr<float>(v);
      const uint16_t* l = lab.ptr<uint16_t>(v);
      const uchar* ob = obstacle.ptr<uchar>(v);
      for (int u = 0; u < lab.cols; ++u) {
        if (gd[u] <= 0 || gd[u] > band || od[u] > band || l[u] != 0 || ob[u] || !std::isfinite(x[u])) continue;
        const int k = static_cast<int>(std::ceil(gd[u]));
        sum[k] += x[u], ++cnt[k];
      }
    }
    int rings = 0;
    for (int k = 1; k <= band; ++k) {
      if (cnt[k] < 10) break;
      const double sigma_mean = ring_sigma * ring_window_px / std::sqrt(static_cast<double>(cnt[k]));
      if (sum[k] / cnt[k] < std::max(floor_mm, ring_level + 2.0 * sigma_mean)) break;
      rings = k;
    }
    if (rings == 0) continue;
    for (int v = 0; v < lab.rows; ++v) {
      uint16_t* l = lab.ptr<uint16_t>(v);
      const float* gd = grown_dist.ptr<float>(v);
      const float* od = dist.ptr<float>(v);
      const uchar* ob = obstacle.ptr<uchar>(v);
      for (int u = 0; u < lab.cols; ++u)
        if (gd[u] > 0 && gd[u] <= rings && od[u] <= band && l[u] == 0 && !ob[u]) l[u] = static_cast<uint16_t>(id);
    }
  }
}

double CoreWidthM(const cv::Mat& labels, int id, const RoadRelief& r, const cv::Mat& pixel_area_m2,
                  double min_depth_m, cv::Rect box) {
  cv::Rect roi = box.empty() ? cv::boundingRect(labels == id) : box;
  if (roi.empty()) return 0;
  roi = cv::Rect(roi.x - 1, roi.y - 1, roi.width + 2, roi.height + 2) & cv::Rect({}, labels.size());
  // NaN depth compares false: unmatched pixels are not part of the core.
  const cv::Mat core = (labels(roi) == id) & (r.depth_below_mm(roi) >= min_depth_m * 1000.0);
  cv::Mat padded, dist;
  cv::copyMakeBorder(core, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  cv::distanceTransform(padded, dist, cv::DIST_L2, cv::DIST_MASK_5);
  double best = 0;
  for (int v = 0; v < core.rows; ++v) {
    const float* ar = pixel_area_m2.ptr<float>(roi.y + v) + roi.x;
    const float* dr = dist.ptr<float>(v + 1) + 1;
    for (int u = 0; u < core.cols; ++u) {
      const float a = ar[u], dpx = dr[u];
      if (dpx > 0 && std::isfinite(a)) best = std::max(best, 2.0 * dpx * std::sqrt(double(a)));
    }
  }
  return best;
}

std::vector<DamageInstance> MeasureDepressions(const cv::Mat& labels, const RoadRelief& r, const StereoGeometry& g,
                                               const RoadSurface& s, const MeasureOptions& o, const cv::Mat& noise_px) {
  if (labels.type() != CV_16UC1 || labels.size() != r.depth_below_mm.size())
    throw std::invalid_argument("MeasureDepressions: labels must be CV_16U of the relief's size");
  if (!noise_px.empty() && (noise_px.type() != CV_32FC1 || noise_px.size() != labels.size()))
    throw std::invalid_argument("MeasureDepressions: noise_px must be CV_32F of the labels' size");
  const double fb = g.f_px * g.baseline_m;
  o.Check();
  const cv::Mat area = PixelAreaOnRoad(r, g, s);
  double maxv = 0;
  cv::minMaxLoc(labels, nullptr, &maxv);
  const int n = static_cast<int>(maxv);
  struct Acc {
    std::vector<double> depth;
    double area = 0, area_valid = 0, volume = 0, z = 0, noise_mm = 0;
    int pixels = 0, invalid = 0;
  };
  std::vector<Acc> acc(n + 1);
  for (int v = 0; v < labels.rows; ++v) {
    const uint16_t* l = labels.ptr<uint16_t>(v);
    const float* d = r.depth_below_mm.ptr<float>(v);
    const float* a = area.ptr<float>(v);
    const float* z = r.road_depth_m.ptr<float>(v);
    for (int u = 0; u < labels.cols; ++u) {
      if (!l[u] || !std::isfinite(a[u])) continue;
      Acc& c = acc[l[u]];
      ++c.pixels;
      c.area += a[u];
      c.z += z[u];
      if (!noise_px.empty()) {
        // Disparity noise as depth below the surface: a point moved along its ray by
        // ΔZ = Z²·σ_d/(f·B) changes its height by ΔZ·|n·ray|.
        const double nr = std::abs(s.normal.x() * (u - g.cx_px) / g.f_px + s.normal.y() * (v - g.cy_px) / g.f_px +
                                   s.normal.z());
        c.noise_mm += 1000.0 * noise_px.at<float>(v, u) * double(z[u]) * z[u] / fb * nr;
      }
      if (std::isfinite(d[u])) {
        const double depth_m = d[u] / 1000.0;
        c.depth.push_back(depth_m);
        c.area_valid += a[u];
        c.volume += std::max(0.0, depth_m) * a[u];  // material above the road is not missing volume
      } else {
        ++c.invalid;
      }
    }
  }
  const std::vector<cv::Rect> boxes = LabelBoxes(labels);
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
      auto it = c.depth.begin() + static_cast<long>(o.depth_percentile * (c.depth.size() - 1));
      std::nth_element(c.depth.begin(), it, c.depth.end());
      d.max_depth_m = *it;
      d.volume_m3 = c.volume + std::max(0.0, d.mean_depth_m) * (c.area - c.area_valid);
    }
    d.equivalent_diameter_m = std::sqrt(4.0 * d.area_m2 / CV_PI);
    d.outline_px = OutlineOf(labels, id, boxes[id]);
    std::vector<Eigen::Vector3d> ring;
    for (const cv::Point& p : d.outline_px) {
      const double z = s.RayDepth(g, p.x, p.y);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d q((p.x - g.cx_px) * z / g.f_px, (p.y - g.cy_px) * z / g.f_px, z);
      ring.push_back(q);
      d.outline_cam_m.emplace_back(q.x(), q.y(), q.z());
    }
    double dmax = 0;
    for (size_t i = 0; i < ring.size(); ++i)
      for (size_t j = i + 1; j < ring.size(); ++j) dmax = std::max(dmax, (ring[i] - ring[j]).norm());
    d.max_diameter_m = dmax;
    const bool deep = std::isfinite(d.max_depth_m) && d.max_depth_m >= o.pothole_min_depth_m &&
                      d.max_depth_m >= o.pothole_min_depth_sigma * d.sigma_depth_m &&
                      1000.0 * d.max_depth_m >= o.pothole_min_noise_sigma * c.noise_mm / c.pixels;
    const bool compact = d.max_diameter_m > 0 && d.area_m2 >= o.pothole_min_compactness * CV_PI / 4 *
                                                                  d.max_diameter_m * d.max_diameter_m;
    const bool wide = deep && compact && d.equivalent_diameter_m >= o.pothole_min_diameter_m &&
                      CoreWidthM(labels, id, r, area, 0.5 * d.max_depth_m, boxes[id]) >= o.pothole_min_core_width_m;
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
