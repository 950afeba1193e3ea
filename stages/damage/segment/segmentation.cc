#include "stages/damage/segment/segmentation.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/slic.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "survey/stats/order_statistic.h"
#include "stages/damage/road/relief_smooth.h"
#include "stages/damage/segment/rect_merge.h"

namespace rs {
namespace {

cv::Mat Disk(int r) { return cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}); }

// Keeps the components of `grow` that contain at least one pixel of `seed`.
cv::Mat Hysteresis(const cv::Mat& seed, const cv::Mat& grow) {
  cv::Mat cc;
  const int n = cv::connectedComponents(grow, cc, 8, CV_32S);
  std::vector<char> keep(n, 0);
  // Rows in parallel: every writer stores the same value 1 (relaxed atomic stores, no race).
  tbb::parallel_for(0, seed.rows, [&](int v) {
    const uchar* s = seed.ptr<uchar>(v);
    const int* c = cc.ptr<int>(v);
    for (int u = 0; u < seed.cols; ++u)
      if (s[u] && c[u] > 0) std::atomic_ref<char>(keep[c[u]]).store(1, std::memory_order_relaxed);
  });
  cv::Mat out(seed.size(), CV_8U);
  tbb::parallel_for(0, seed.rows, [&](int v) {
    const int* c = cc.ptr<int>(v);
    uchar* o = out.ptr<uchar>(v);
    for (int u = 0; u < seed.cols; ++u) o[u] = keep[c[u]] ? 255 : 0;
  });
  return out;
}

// Adds the invalid (unmatched) patches whose border is largely damage: stereo fails inside deep
// potholes (occluded far wall, shadow), and those pixels belong to the pothole.
void FillInvalidInside(cv::Mat& mask, const cv::Mat& valid, double fraction) {
  cv::Mat invalid = valid == 0;
  cv::Mat cc;
  const int n = cv::connectedComponents(invalid, cc, 8, CV_32S);
  if (n <= 1) return;
  std::vector<int> ring(n, 0), ring_damage(n, 0);
  // Ring = valid pixels 4-adjacent to an invalid component (each component counted once per pixel).
  for (int v = 0; v < mask.rows; ++v) {
    const int* c = cc.ptr<int>(v);
    const int* up = v > 0 ? cc.ptr<int>(v - 1) : nullptr;
    const int* down = v + 1 < mask.rows ? cc.ptr<int>(v + 1) : nullptr;
    const uchar* m = mask.ptr<uchar>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (c[u] != 0) continue;
      const int nb[4] = {u > 0 ? c[u - 1] : 0, u + 1 < mask.cols ? c[u + 1] : 0, up ? up[u] : 0, down ? down[u] : 0};
      int last = 0;
      for (int id : nb) {
        if (id == 0 || id == last) continue;
        last = id;
        ++ring[id];
        ring_damage[id] += m[u] != 0;
      }
    }
  }
  for (int v = 0; v < mask.rows; ++v) {
    const int* c = cc.ptr<int>(v);
    uchar* m = mask.ptr<uchar>(v);
    for (int u = 0; u < mask.cols; ++u)
      if (c[u] > 0 && ring[c[u]] > 0 && ring_damage[c[u]] >= fraction * ring[c[u]]) m[u] = 255;
  }
}

// Disjoint regions of interest around the candidate regions: each component's bounding box
// grown by `pad`, overlapping boxes merged until none overlap.
std::vector<cv::Rect> CandidateRois(const cv::Mat& mask, int pad) {
  cv::Mat cc, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, cc, stats, centroids, 8, CV_32S);
  const cv::Rect frame({}, mask.size());
  std::vector<cv::Rect> rois;
  for (int i = 1; i < n; ++i)
    rois.push_back(cv::Rect(stats.at<int>(i, cv::CC_STAT_LEFT) - pad, stats.at<int>(i, cv::CC_STAT_TOP) - pad,
                            stats.at<int>(i, cv::CC_STAT_WIDTH) + 2 * pad,
                            stats.at<int>(i, cv::CC_STAT_HEIGHT) + 2 * pad) &
                   frame);
  MergeOverlappingRects(&rois);
  return rois;
}

// Snaps the mask inside `roi` to SLIC superpixel boundaries. `elongation`: road length of a
// pixel along the column / across it at the roi (1: square pixels on the road).
void SnapRoiToSuperpixels(cv::Mat& mask, const cv::Mat& z, const cv::Mat& valid, const cv::Rect& roi,
                          const SegmentOptions& o, double elongation) {
  // SLIC sees the relief clipped to [-20σ, +5σ] as 8-bit; invalid pixels take the candidate's level
  // so they do not cut superpixels.
  cv::Mat img(roi.size(), CV_8U);
  for (int v = 0; v < roi.height; ++v) {
    const float* zr = z.ptr<float>(v + roi.y) + roi.x;
    const uchar* va = valid.ptr<uchar>(v + roi.y) + roi.x;
    const uchar* m = mask.ptr<uchar>(v + roi.y) + roi.x;
    uchar* out = img.ptr<uchar>(v);
    for (int u = 0; u < roi.width; ++u) {
      const double zz = va[u] ? zr[u] : (m[u] ? -20.0 : 0.0);
      out[u] = cv::saturate_cast<uchar>((std::clamp(zz, -20.0, 5.0) + 20.0) * 10.0);
    }
  }
  // Superpixels of 8 px or more are found at half resolution (a quarter of the work; the relief
  // is box-smoothed over 7 px anyway) and voted on at full resolution. In an oblique view
  // (elongation ≥ 1.5) the roi is instead resampled by k·√e across and k / √e along the column,
  // so superpixels of the same pixel count are square on the road: a square 16-px superpixel
  // spans 0.4 m of road along the view at 6 m from a car, more than a 0.3 m pothole.
  const int k = o.slic_region_size_px >= 8 ? 2 : 1;
  const double root_e = o.slic_ground && elongation >= kObliqueElongation ? std::sqrt(elongation) : 1.0;
  const double sx = k * root_e, sy = k / root_e;  // full-resolution pixels per resampled pixel
  cv::Mat small = img;
  if (root_e > 1.0)
    cv::resize(img, small,
               cv::Size(std::max(1, static_cast<int>(std::lround(roi.width / sx))),
                        std::max(1, static_cast<int>(std::lround(roi.height / sy)))),
               0, 0, cv::INTER_AREA);
  else if (k > 1)
    cv::resize(img, small, cv::Size((roi.width + 1) / 2, (roi.height + 1) / 2), 0, 0, cv::INTER_AREA);
  auto slic = cv::ximgproc::createSuperpixelSLIC(small, cv::ximgproc::SLICO, o.slic_region_size_px / k,
                                                 static_cast<float>(o.slic_ruler));
  slic->iterate(3);
  cv::Mat sp;
  slic->getLabels(sp);
  const int n = slic->getNumberOfSuperpixels();
  // Column and row of the resampled image holding each full-resolution column / row.
  std::vector<int> col(roi.width), row(roi.height);
  for (int u = 0; u < roi.width; ++u) col[u] = std::min(root_e > 1.0 ? static_cast<int>(u / sx) : u / k, sp.cols - 1);
  for (int v = 0; v < roi.height; ++v) row[v] = std::min(root_e > 1.0 ? static_cast<int>(v / sy) : v / k, sp.rows - 1);
  std::vector<int> total(n, 0), hit(n, 0);
  cv::Mat sub = mask(roi);
  for (int v = 0; v < roi.height; ++v) {
    const int* l = sp.ptr<int>(row[v]);
    const uchar* m = sub.ptr<uchar>(v);
    for (int u = 0; u < roi.width; ++u) {
      const int id = l[col[u]];
      ++total[id];
      hit[id] += m[u] != 0;
    }
  }
  for (int v = 0; v < roi.height; ++v) {
    const int* l = sp.ptr<int>(row[v]);
    uchar* m = sub.ptr<uchar>(v);
    for (int u = 0; u < roi.width; ++u) {
      const int id = l[col[u]];
      m[u] = hit[id] >= o.superpixel_vote * total[id] ? 255 : 0;
    }
  }
}

// Snaps the mask to SLIC superpixel boundaries around each group of candidate regions only
// (work in proportion to the damage, not the frame; disjoint regions run in parallel).
void SnapToSuperpixels(cv::Mat& mask, const cv::Mat& z, const cv::Mat& valid, const SegmentOptions& o,
                       const std::vector<double>& row_elongation) {
  const std::vector<cv::Rect> rois = CandidateRois(mask, 2 * o.slic_region_size_px);
  tbb::parallel_for(size_t(0), rois.size(), [&](size_t i) {
    const int centre = rois[i].y + rois[i].height / 2;
    const double e = centre < static_cast<int>(row_elongation.size()) ? row_elongation[centre] : 1.0;
    SnapRoiToSuperpixels(mask, z, valid, rois[i], o, e);
  });
}

}  // namespace

void FillHoles(cv::Mat& mask) {
  cv::Mat padded;
  cv::copyMakeBorder(mask, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  cv::floodFill(padded, cv::Point(0, 0), 128);
  cv::Mat holes = padded(cv::Rect(1, 1, mask.cols, mask.rows)) == 0;
  mask.setTo(255, holes);
}

ReliefImage ToRelief(const cv::Mat& image) {
  if (image.empty() || image.channels() != 1)
    throw std::invalid_argument("relief image must be a non-empty single-channel image");
  ReliefImage r;
  const int depth = image.depth();
  if (depth == CV_8U || depth == CV_16U || depth == CV_8S || depth == CV_16S || depth == CV_32S) {
    image.convertTo(r.value, CV_32F);
    r.valid = image != 0;
  } else if (depth == CV_32F || depth == CV_64F) {
    image.convertTo(r.value, CV_32F);
    r.valid.create(image.size(), CV_8U);
    for (int v = 0; v < image.rows; ++v) {
      const float* x = r.value.ptr<float>(v);
      uchar* m = r.valid.ptr<uchar>(v);
      for (int u = 0; u < image.cols; ++u) m[u] = std::isfinite(x[u]) && x[u] > 0 ? 255 : 0;
    }
  } else {
    throw std::invalid_argument("relief image depth not supported (use 8/16-bit integer or float)");
  }
  return r;
}

ReliefScale EstimateReliefScale(const ReliefImage& relief) {
  std::vector<float> vals;
  vals.reserve(relief.value.total() / 4 + 1);
  // Every second pixel in u and v: plenty for a histogram, four times faster.
  for (int v = 0; v < relief.value.rows; v += 2) {
    const float* x = relief.value.ptr<float>(v);
    const uchar* m = relief.valid.ptr<uchar>(v);
    for (int u = 0; u < relief.value.cols; u += 2)
      if (m[u]) vals.push_back(x[u]);
  }
  if (vals.size() < 100) throw std::invalid_argument("relief image: fewer than 100 valid pixels");
  // Histogram between the 1st and 99th percentiles, smoothed; its peak is the road level.
  auto at = [&](double q) { return static_cast<double>(KthSmallestInPlace(vals, QuantileRankDown(q, vals.size()))); };
  double lo = at(0.01), hi = at(0.99);
  ReliefScale s;
  if (!(hi > lo)) {  // constant image: no noise to measure
    s.road_level = lo;
    s.sigma = std::max(1e-6, std::abs(lo) * 1e-6);
    return s;
  }
  // Integer images: one bin per code value, centred on it, so quantisation does not bias σ.
  const bool integer = std::all_of(vals.begin(), vals.end(), [](float x) { return x == std::floor(x); });
  constexpr int kMaxBins = 512;
  double bw = (hi - lo) / kMaxBins;
  if (integer) bw = std::max(1.0, std::ceil(bw)), lo = std::floor(lo) - 0.5;
  const int bins = std::max(3, static_cast<int>(std::ceil((hi - lo) / bw)) + 1);
  std::vector<double> hist(bins, 0.0);
  double above = 0;  // values beyond the histogram: all in the upper half
  for (float x : vals) {
    if (x < lo) continue;
    const int b = static_cast<int>((x - lo) / bw);
    if (b >= bins)
      above += 1;
    else
      hist[b] += 1;
  }
  std::vector<double> sm(bins, 0.0);
  for (int i = 0; i < bins; ++i)
    for (int k = -4; k <= 4; ++k)
      if (i + k >= 0 && i + k < bins) sm[i] += hist[i + k] * std::exp(-0.5 * k * k / 4.0);
  const int peak = static_cast<int>(std::max_element(sm.begin(), sm.end()) - sm.begin());
  double off = 0;  // parabolic refinement of the peak
  if (peak > 0 && peak + 1 < bins) {
    const double den = sm[peak - 1] - 2 * sm[peak] + sm[peak + 1];
    if (den < 0) off = std::clamp(0.5 * (sm[peak - 1] - sm[peak + 1]) / den, -0.5, 0.5);
  }
  const double level = lo + (peak + 0.5 + off) * bw;
  // σ from the upper half: the median of (x − level) over x > level is 0.6745σ for a Gaussian.
  // Mass above x with each bin's count spread uniformly over its width.
  std::vector<double> tail(bins + 1, 0.0);  // tail[i] = mass of bins i.. plus `above`
  tail[bins] = above;
  for (int i = bins - 1; i >= 0; --i) tail[i] = tail[i + 1] + hist[i];
  auto mass_above = [&](double x) {
    const double pos = std::clamp((x - lo) / bw, 0.0, static_cast<double>(bins));
    const int i = std::min(bins - 1, static_cast<int>(pos));
    return tail[i + 1] + hist[i] * (i + 1 - pos);
  };
  const double target = 0.5 * mass_above(level);
  double a = level, b = lo + bins * bw;  // bisection: mass_above is non-increasing
  for (int it = 0; it < 60; ++it) {
    const double m = 0.5 * (a + b);
    (mass_above(m) > target ? a : b) = m;
  }
  s.road_level = level;
  s.sigma = std::max((0.5 * (a + b) - level) / 0.6745, 1e-9);
  return s;
}

double EnergyThresholdSigma(const cv::Mat& z, const cv::Mat& valid, const SegmentOptions& o) {
  // Histogram of z on [-zmax, 6], bins of 0.25σ. Damage deeper than zmax piles into the first bin.
  const double zmax = std::max(60.0, 2 * o.max_threshold_sigma), bw = 0.25;
  const int bins = static_cast<int>((zmax + 6.0) / bw);
  // Integer counts per band of rows, summed afterwards: exact, the same for any split.
  constexpr int kBands = 8;
  std::vector<std::vector<int>> hb(kBands, std::vector<int>(bins, 0));
  tbb::parallel_for(0, kBands, [&](int k) {
    std::vector<int>& hk = hb[k];
    for (int v = z.rows * k / kBands; v < z.rows * (k + 1) / kBands; ++v) {
      const float* zr = z.ptr<float>(v);
      const uchar* m = valid.ptr<uchar>(v);
      for (int u = 0; u < z.cols; ++u) {
        if (!m[u] || !(zr[u] <= 6.0f)) continue;
        ++hk[std::clamp(static_cast<int>((zr[u] + zmax) / bw), 0, bins - 1)];
      }
    }
  });
  std::vector<double> h(bins, 0.0);
  for (const std::vector<int>& hk : hb)
    for (int i = 0; i < bins; ++i) h[i] += hk[i];
  double n = 0, sum = 0;
  for (int i = 0; i < bins; ++i) n += h[i], sum += h[i] * (-zmax + (i + 0.5) * bw);
  // Two-class energy: within-class squared error, minimised where n1·n2·(m1 − m2)² is largest.
  double best_t = o.min_threshold_sigma, best = -1, n1 = 0, s1 = 0;
  for (int k = 1; k < bins; ++k) {
    n1 += h[k - 1], s1 += h[k - 1] * (-zmax + (k - 0.5) * bw);
    const double n2 = n - n1;
    if (n1 <= 0 || n2 <= 0) continue;
    const double d = s1 / n1 - (sum - s1) / n2;
    const double between = n1 * n2 * d * d;
    if (between > best) best = between, best_t = zmax - k * bw;
  }
  return std::clamp(best_t, o.min_threshold_sigma, o.max_threshold_sigma);
}

DepressionSegmentation SegmentDepressions(const ReliefImage& relief, const SegmentOptions& o,
                                          const cv::Mat& pixel_area_m2, std::optional<ReliefScale> scale,
                                          const cv::Mat& noise_sigma, const cv::Mat& noisy_class) {
  if (relief.value.type() != CV_32FC1 || relief.valid.type() != CV_8UC1 || relief.value.size() != relief.valid.size())
    throw std::invalid_argument("SegmentDepressions: relief must be CV_32F with a CV_8U mask of the same size");
  if (!pixel_area_m2.empty() && (pixel_area_m2.type() != CV_32FC1 || pixel_area_m2.size() != relief.value.size()))
    throw std::invalid_argument("SegmentDepressions: pixel_area_m2 must be CV_32F of the relief's size");
  DepressionSegmentation out;
  out.scale = scale ? *scale : EstimateReliefScale(relief);
  if (!(out.scale.sigma > 0)) throw std::invalid_argument("SegmentDepressions: relief scale sigma must be > 0");
  if (!noise_sigma.empty() && (noise_sigma.type() != CV_32FC1 || noise_sigma.size() != relief.value.size()))
    throw std::invalid_argument("SegmentDepressions: noise_sigma must be CV_32F of the relief's size");
  if (!noisy_class.empty() &&
      (noise_sigma.empty() || noisy_class.type() != CV_8UC1 || noisy_class.size() != relief.value.size()))
    throw std::invalid_argument("SegmentDepressions: noisy_class must be CV_8U of the relief's size, with noise_sigma");
  cv::Mat z;
  relief.value.convertTo(z, CV_32F, 1.0 / out.scale.sigma, -out.scale.road_level / out.scale.sigma);
  out.threshold_sigma = EnergyThresholdSigma(z, relief.valid, o);
  cv::Mat seed = (z < -out.threshold_sigma) & relief.valid;
  cv::Mat grow = (z < -o.grow_fraction * out.threshold_sigma) & relief.valid;
  if (!noise_sigma.empty()) {
    // Seeds must also be significant against the noise where they lie: at least
    // min_threshold_sigma local σ below the road. Quiet regions keep the frame's threshold;
    // growth stays on the frame's σ, so a seeded region is not cut by the noise estimate's
    // own rise around large damage (the local road correction's misfit there).
    const float level = static_cast<float>(out.scale.road_level), k = static_cast<float>(o.min_threshold_sigma);
    tbb::parallel_for(0, seed.rows, [&](int v) {  // seeds are sparse: test only them
      uchar* sd = seed.ptr<uchar>(v);
      const float* x = relief.value.ptr<float>(v);
      const float* ns = noise_sigma.ptr<float>(v);
      for (int u = 0; u < seed.cols; ++u)
        if (sd[u] && !(x[u] - level < -k * ns[u])) sd[u] = 0;
    });
    // Significant where it lies is enough: deep damage elsewhere in the frame raises the energy
    // threshold (13–14 σ beside 120 mm potholes) above shallow potholes that stand
    // seed_noise_sigma local σ out.
    if (o.seed_noise_sigma > 0) {
      const float k2 = static_cast<float>(o.seed_noise_sigma);
      tbb::parallel_for(0, seed.rows, [&](int v) {
        uchar* sd = seed.ptr<uchar>(v);
        const uchar* m = relief.valid.ptr<uchar>(v);
        const float* x = relief.value.ptr<float>(v);
        const float* ns = noise_sigma.ptr<float>(v);
        for (int u = 0; u < seed.cols; ++u)
          if (m[u] && x[u] - level < -k2 * ns[u]) sd[u] = 255;
      });
    }
    out.noise_sigma = noise_sigma;
    // A noisier class grows only as deep as it seeds: its wrong winners, though shallower than a
    // seed, reach the frame's growth threshold and carried a region along a paint line.
    if (!noisy_class.empty()) {
      tbb::parallel_for(0, grow.rows, [&](int v) {
        uchar* gr = grow.ptr<uchar>(v);
        const uchar* c = noisy_class.ptr<uchar>(v);
        const float* x = relief.value.ptr<float>(v);
        const float* ns = noise_sigma.ptr<float>(v);
        for (int u = 0; u < grow.cols; ++u)
          if (gr[u] && c[u] && !(x[u] - level < -k * ns[u])) gr[u] = 0;
      });
    }
  }
  // Seeds must survive a small opening, so isolated noisy pixels do not start regions.
  if (o.morph_radius_px > 0) cv::morphologyEx(seed, seed, cv::MORPH_OPEN, Disk(o.morph_radius_px));
  cv::Mat mask = Hysteresis(seed, grow);
  FillInvalidInside(mask, relief.valid, o.invalid_fill_fraction);
  if (o.slic_region_size_px > 0) SnapToSuperpixels(mask, z, relief.valid, o, relief.row_elongation);
  if (o.morph_radius_px > 0) {
    cv::morphologyEx(mask, mask, cv::MORPH_OPEN, Disk(o.morph_radius_px));
    cv::morphologyEx(mask, mask, cv::MORPH_CLOSE, Disk(o.morph_radius_px));
  }
  FillHoles(mask);

  cv::Mat cc, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, cc, stats, centroids, 8, CV_32S);
  std::vector<double> area(n, 0.0);
  if (!pixel_area_m2.empty()) {
    for (int v = 0; v < cc.rows; ++v) {
      const int* c = cc.ptr<int>(v);
      const float* a = pixel_area_m2.ptr<float>(v);
      for (int u = 0; u < cc.cols; ++u)
        if (c[u] > 0 && std::isfinite(a[u])) area[c[u]] += a[u];
    }
  }
  std::vector<int> new_id(n, 0);
  for (int i = 1; i < n; ++i) {
    const bool big =
        pixel_area_m2.empty() ? stats.at<int>(i, cv::CC_STAT_AREA) >= o.min_area_px : area[i] >= o.min_area_m2;
    if (!big) {
      ++out.dropped_small;
      continue;
    }
    if (out.count >= 65535) {
      ++out.dropped_small;
      continue;
    }  // 16-bit label image is full
    new_id[i] = ++out.count;
  }
  out.labels.create(mask.size(), CV_16U);  // every pixel written below
  tbb::parallel_for(0, cc.rows, [&](int v) {
    const int* c = cc.ptr<int>(v);
    uint16_t* l = out.labels.ptr<uint16_t>(v);
    for (int u = 0; u < cc.cols; ++u) l[u] = static_cast<uint16_t>(new_id[c[u]]);
  });
  return out;
}

}  // namespace rs
