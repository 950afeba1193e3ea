#include "stages/damage/cracks/cracks.h"

#include "stages/damage/cracks/crack_net.h"
#include "stages/damage/cracks/ridge.h"
#include "stages/damage/measure/measure.h"
#include "survey/stats/order_statistic.h"
#include "survey/stats/robust_stats.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace rs {

namespace {

cv::Mat Grey(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw std::invalid_argument("DetectCracks: image must be 8-bit grey or BGR");
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else
    grey = image;
  return grey;
}

// Black-hat of the opened image: the opening first removes bright grains narrower than the
// element (aggregate stones), so the dark binder between them no longer responds; a crack, dark
// and thin, survives the opening and responds against the binder level around it.
cv::Mat BlackHat(const cv::Mat& grey, int k) {
  const cv::Mat element = cv::getStructuringElement(cv::MORPH_ELLIPSE, {k, k});
  cv::Mat opened, bh;
  cv::morphologyEx(grey, opened, cv::MORPH_OPEN, element);
  cv::morphologyEx(opened, bh, cv::MORPH_BLACKHAT, element);
  return bh;
}

// Multi-scale black-hat: closing fills dark structures narrower than the element.
cv::Mat PixelScaleResponse(const cv::Mat& grey, const CrackOptions& o) {
  cv::Mat response = cv::Mat::zeros(grey.size(), CV_8U);
  for (int k = o.min_scale_px; k <= o.max_scale_px; k += 4) response = cv::max(response, BlackHat(grey, k));
  return response;
}

// Element per image row: odd pixel count spanning element_width_m of road at the row's median
// pixel size (a forward or nadir camera's pixel size changes along the column, little along a
// row); rows without road get none (0).
std::vector<int> RowElements(const cv::Mat& pixel_size_m, const CrackOptions& o) {
  std::vector<int> k_row(pixel_size_m.rows, 0);
  std::vector<float> ps;
  for (int v = 0; v < pixel_size_m.rows; ++v) {
    ps.clear();
    const float* p = pixel_size_m.ptr<float>(v);
    for (int u = 0; u < pixel_size_m.cols; u += 8)
      if (std::isfinite(p[u]) && p[u] > 0) ps.push_back(p[u]);
    if (ps.size() < 4) continue;
    const double w_px = o.element_width_m / LowerMedianInPlace(ps);
    const int k = 2 * static_cast<int>(std::lround((w_px - 1) / 2)) + 1;
    k_row[v] = std::clamp(k, o.min_scale_px, o.max_scale_px);
  }
  return k_row;
}

// Black-hat with the element of each row: one pass per element size over its band of rows
// (plus the element's reach), about one full-frame black-hat in all.
cv::Mat MetricResponse(const cv::Mat& grey, const cv::Mat& pixel_size_m, const CrackOptions& o) {
  const std::vector<int> k_row = RowElements(pixel_size_m, o);
  cv::Mat response = cv::Mat::zeros(grey.size(), CV_8U);
  for (int v0 = 0; v0 < grey.rows;) {
    int v1 = v0;
    while (v1 + 1 < grey.rows && k_row[v1 + 1] == k_row[v0]) ++v1;
    if (const int k = k_row[v0]; k > 0) {
      const int a = std::max(0, v0 - k), b = std::min(grey.rows, v1 + 1 + k);
      const cv::Mat bh = BlackHat(grey.rowRange(a, b), k);
      bh.rowRange(v0 - a, v1 + 1 - a).copyTo(response.rowRange(v0, v1 + 1));
    }
    v0 = v1 + 1;
  }
  return response;
}

cv::Mat ResponseOfGrey(const cv::Mat& grey, const cv::Mat& pixel_size_m, const CrackOptions& o) {
  return pixel_size_m.empty() || !(o.element_width_m > 0) ? PixelScaleResponse(grey, o)
                                                          : MetricResponse(grey, pixel_size_m, o);
}

// Median and robust σ (1.4826·MAD, at least 1 grey level) of a sample; false when too small.
bool RobustLevel(std::vector<uchar>& vals, double* med, double* sigma) {
  if (vals.size() < 100) return false;
  // Grey levels counted once: the median and the MAD (both the lower median v[n/2], as
  // nth_element) follow from the counts and the absolute deviations' counts.
  size_t count[256] = {0};
  for (uchar x : vals) ++count[x];
  const size_t k = vals.size() / 2;
  const int m = KthSmallestOfCounts(count, 256, k);
  *med = m;
  size_t dev[256] = {0};
  for (int x = 0; x < 256; ++x) dev[std::abs(x - m)] += count[x];
  *sigma = std::max(1.0, SigmaOfMedianAbs(KthSmallestOfCounts(dev, 256, k)));
  return true;
}

// Every 4th pixel in u and v of `image` (CV_8U) where `search` is set: enough for a robust level.
std::vector<uchar> SearchedSamples(const cv::Mat& image, const cv::Mat& search) {
  std::vector<uchar> vals;
  for (int v = 0; v < image.rows; v += 4) {
    const uchar* sr = search.ptr<uchar>(v);
    const uchar* rr = image.ptr<uchar>(v);
    for (int u = 0; u < image.cols; u += 4)
      if (sr[u]) vals.push_back(rr[u]);
  }
  return vals;
}

// Per-cell median and σ of the response over the searched pixels (every 3rd pixel), cells with
// too few samples filled from their neighbours (or the frame's level): CV_32FC2, one per cell
// (1 × 1: one level per frame).
cv::Mat LocalLevelGrid(const cv::Mat& response, const cv::Mat& search, const CrackOptions& o, double med,
                       double sigma) {
  if (o.level_cell_px <= 0) return cv::Mat(1, 1, CV_32FC2, cv::Scalar(med, sigma));
  const int cell = o.level_cell_px;
  const int nx = (response.cols + cell - 1) / cell, ny = (response.rows + cell - 1) / cell;
  cv::Mat grid(ny, nx, CV_32FC2, cv::Scalar(NAN, NAN));
  std::vector<uchar> vals;
  for (int cy = 0; cy < ny; ++cy)
    for (int cx = 0; cx < nx; ++cx) {
      vals.clear();
      for (int v = cy * cell; v < std::min(response.rows, (cy + 1) * cell); v += 3) {
        const uchar* sr = search.ptr<uchar>(v);
        const uchar* rr = response.ptr<uchar>(v);
        for (int u = cx * cell; u < std::min(response.cols, (cx + 1) * cell); u += 3)
          if (sr[u]) vals.push_back(rr[u]);
      }
      double m, s;
      if (RobustLevel(vals, &m, &s)) grid.at<cv::Vec2f>(cy, cx) = cv::Vec2f(float(m), float(s));
    }
  for (bool missing = true; missing;) {  // grow known cells into empty ones (mean of known neighbours)
    missing = false;
    cv::Mat next = grid.clone();
    bool any_known = false;
    for (int cy = 0; cy < ny; ++cy)
      for (int cx = 0; cx < nx; ++cx) {
        if (!std::isnan(grid.at<cv::Vec2f>(cy, cx)[0])) {
          any_known = true;
          continue;
        }
        cv::Vec2f sum(0, 0);
        int n = 0;
        for (int y = std::max(0, cy - 1); y <= std::min(ny - 1, cy + 1); ++y)
          for (int x = std::max(0, cx - 1); x <= std::min(nx - 1, cx + 1); ++x)
            if (const cv::Vec2f g = grid.at<cv::Vec2f>(y, x); !std::isnan(g[0])) sum += g, ++n;
        if (n)
          next.at<cv::Vec2f>(cy, cx) = sum / n;
        else
          missing = true;
      }
    if (!any_known) return cv::Mat(1, 1, CV_32FC2, cv::Scalar(med, sigma));
    grid = next;
  }
  return grid;
}

// a·median + b·σ of a level grid, bilinear between cell centres, as an 8-bit map of `size`
// (the response is 8-bit: whole grey levels suffice, and 8-bit maps keep the per-pixel tests cheap).
cv::Mat LevelMap(const cv::Mat& grid, double a, double b, cv::Size size) {
  cv::Mat ch[2], small8, out;
  cv::split(grid, ch);
  cv::Mat small = a * ch[0] + b * ch[1];
  small.convertTo(small8, CV_8U);
  cv::resize(small8, out, size, 0, 0, cv::INTER_LINEAR);
  return out;
}

// Oriented line support of the response, at half resolution: per pixel the largest mean of
// the response along a line of `length_px` (full-resolution pixels) in 8 directions, minus the
// mean over the directions. A crack is dark along its direction only; the gaps between
// aggregate stones respond as strongly pixel by pixel but not along any line, and a dark blob
// (shadow, stain) in every direction. CV_8U at full resolution.
cv::Mat LineSupport(const cv::Mat& response, int length_px) {
  cv::Mat half;
  cv::resize(response, half, cv::Size((response.cols + 1) / 2, (response.rows + 1) / 2), 0, 0, cv::INTER_AREA);
  const int h = std::clamp(length_px / 4, 1, 15);  // taps -h..h at half resolution (16-bit sums)
  cv::Mat padded;
  cv::copyMakeBorder(half, padded, h, h, h, h, cv::BORDER_REPLICATE);
  padded.convertTo(padded, CV_16U);
  const cv::Rect core(h, h, half.cols, half.rows);
  // 16-bit sums suffice: 8 directions × 11 taps × 255 < 65536.
  cv::Mat best = cv::Mat::zeros(half.size(), CV_16U), sum_all = cv::Mat::zeros(half.size(), CV_16U), acc;
  constexpr int kDirections = 8;
  for (int i = 0; i < kDirections; ++i) {
    const double th = CV_PI * i / kDirections;
    acc = cv::Mat::zeros(half.size(), CV_16U);
    for (int t = -h; t <= h; ++t) {
      const int dx = static_cast<int>(std::lround(t * std::cos(th))),
                dy = static_cast<int>(std::lround(t * std::sin(th)));
      acc += padded(core + cv::Point(dx, dy));
    }
    best = cv::max(best, acc);
    sum_all += acc;
  }
  const double taps = 2 * h + 1;
  cv::Mat support_half;  // (best − mean over directions) / taps, grey levels
  cv::Mat diff = best * kDirections - sum_all;
  diff.convertTo(support_half, CV_8U, 1.0 / (kDirections * taps));
  cv::Mat support;
  cv::resize(support_half, support, response.size(), 0, 0, cv::INTER_LINEAR);
  return support;
}

// Removes skeleton end pixels `n` times: the spurs thinning grows from a ragged outline (up to
// n px) vanish, every remaining branch end is n px shorter. Returns the number of end pixels left.
int PruneSpurs(cv::Mat& skel, int n) {
  auto neighbours = [&](cv::Point p) {
    int c = 0;
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du) {
        const int uu = p.x + du, vv = p.y + dv;
        if ((du || dv) && uu >= 0 && vv >= 0 && uu < skel.cols && vv < skel.rows && skel.at<uchar>(vv, uu)) ++c;
      }
    return c;
  };
  std::vector<cv::Point> pts, ends;
  cv::findNonZero(skel, pts);
  for (int it = 0; it <= n; ++it) {
    ends.clear();
    for (const cv::Point& p : pts)
      if (skel.at<uchar>(p) && neighbours(p) == 1) ends.push_back(p);
    if (it == n) break;
    for (const cv::Point& p : ends) skel.at<uchar>(p) = 0;
  }
  return static_cast<int>(ends.size());
}

// Thinning leaves L-shaped corners (A, B, C with A–C diagonal): B is redundant for 8-connectivity
// and would make a diagonal step count 2 instead of √2.
void RemoveStaircases(cv::Mat& skel) {
  for (int v = 0; v < skel.rows; ++v)
    for (int u = 0; u < skel.cols; ++u) {
      if (!skel.at<uchar>(v, u)) continue;
      auto on = [&](int uu, int vv) {
        return uu >= 0 && vv >= 0 && uu < skel.cols && vv < skel.rows && skel.at<uchar>(vv, uu) != 0;
      };
      int n = 0;
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du) n += (du || dv) && on(u + du, v + dv);
      if (n != 2) continue;
      // The two neighbours are one horizontal and one vertical 4-neighbour: a corner.
      const bool h = on(u - 1, v) || on(u + 1, v), vert = on(u, v - 1) || on(u, v + 1);
      if (h && vert && !(on(u - 1, v) && on(u + 1, v)) && !(on(u, v - 1) && on(u, v + 1))) skel.at<uchar>(v, u) = 0;
    }
}

// Skeleton (CV_8U) of one candidate component `comp` (CV_8U).
// Thinned from a smoothed outline, since a ragged one grows spurs that add to the length: a 5 × 5
// median for components wider than 2.5 px (it keeps a line only where it is wider than 2.5 px).
// A hairline one or two pixels wide (a crack narrower than a pixel, seen from a few metres) would
// vanish under that median, and Zhang-Suen thinning breaks such a line wherever it steps sideways:
// it is thinned widened by a pixel on each side, which leaves a connected centreline within a
// pixel of it. Width: the component's area over its unsmoothed skeleton's length.
cv::Mat CrackSkeleton(const cv::Mat& comp) {
  cv::Mat skel;
  cv::ximgproc::thinning(comp, skel, cv::ximgproc::THINNING_ZHANGSUEN);
  const double width_px = cv::countNonZero(comp) / std::max(1.0, double(cv::countNonZero(skel)));
  cv::Mat outline;
  if (width_px > 2.5) {
    cv::medianBlur(comp, outline, 5);
    cv::ximgproc::thinning(outline, skel, cv::ximgproc::THINNING_ZHANGSUEN);
    return skel & comp;
  }
  // Two pixels of padding: the widened line must not touch the border, which thinning leaves.
  cv::copyMakeBorder(comp, outline, 2, 2, 2, 2, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::dilate(outline, outline, cv::getStructuringElement(cv::MORPH_RECT, {3, 3}));
  cv::ximgproc::thinning(outline, skel, cv::ximgproc::THINNING_ZHANGSUEN);
  return skel(cv::Rect(2, 2, comp.cols, comp.rows)).clone();
}

// Evidence behind the candidate pixels, for the measurement: `response` (CV_8U) above
// `level_med` (CV_8U) is the darkness profile whose area over its height gives the width;
// classical: black-hat response, its local median and σ (k_sigma: the detection level);
// learned: probability × 255 over a zero level.
struct Evidence {
  cv::Mat response, level_med, level_sigma;
  double k_sigma = 1;
  bool probability = false;
};

// Closes the candidate pixels (CV_8U, non-zero = crack) and measures each component along its
// skeleton; keeps the long, elongated, narrow ones as crack instances in `out` (labels, instances).
// Shared by the classical and the learned detector.
void MeasureComponents(cv::Mat cand, const Evidence& e, const cv::Mat& pixel_size_m, const CrackOptions& o,
                       CrackDetection& out) {
  const cv::Mat& response = e.response;
  const cv::Mat& level_med = e.level_med;
  const cv::Size image_size = cand.size();
  cv::morphologyEx(cand, cand, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, {3, 3}));
  cv::Mat cc, stats, cent;
  const int n = cv::connectedComponentsWithStats(cand, cc, stats, cent, 8, CV_32S);
  int next = 0;
  for (int i = 1; i < n && next < 65535; ++i) {
    if (std::max(stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT)) < o.min_length_px / 2)
      continue;                   // cannot be long enough
    if (!pixel_size_m.empty()) {  // nor on the road: a path is at most √2 × (w + h) px long
      const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
      const float ps = pixel_size_m.at<float>(cvRound(cent.at<double>(i, 1)), cvRound(cent.at<double>(i, 0)));
      if (std::isfinite(ps) && 1.5 * (w + h) * ps < o.min_length_m) continue;
    }
    cv::Rect box(stats.at<int>(i, cv::CC_STAT_LEFT) - 1, stats.at<int>(i, cv::CC_STAT_TOP) - 1,
                 stats.at<int>(i, cv::CC_STAT_WIDTH) + 2, stats.at<int>(i, cv::CC_STAT_HEIGHT) + 2);
    box &= cv::Rect({}, image_size);
    const cv::Mat comp = cc(box) == i;
    cv::Mat skel, dist;
    skel = CrackSkeleton(comp);
    cv::distanceTransform(comp, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    // Spurs grown from the ragged outline reach about the mask's width: pruned up to twice it.
    const double raw_w = cv::mean(dist, skel)[0] * 2.0;
    const int spur_px = std::clamp(static_cast<int>(std::lround(2.0 * raw_w)), 4, 20);
    const int ends = PruneSpurs(skel, spur_px);
    RemoveStaircases(skel);
    const bool metric = !pixel_size_m.empty();
    double len_px = 0, len_m = 0, wsum_px = 0, wsum_m = 0, wmax_m = 0, skel_contrast = 0;
    int nskel = 0;
    for (int v = 0; v < skel.rows; ++v)
      for (int u = 0; u < skel.cols; ++u) {
        if (!skel.at<uchar>(v, u)) continue;
        const double ps = metric ? pixel_size_m.at<float>(v + box.y, u + box.x) : 1.0;
        const double w_px = std::max(1.0, 2.0 * dist.at<float>(v, u) - 1.0);
        ++nskel;
        skel_contrast += response.at<uchar>(v + box.y, u + box.x) - level_med.at<uchar>(v + box.y, u + box.x);
        wsum_px += w_px;
        wsum_m += w_px * ps;
        wmax_m = std::max(wmax_m, w_px * ps);
        // Links to later neighbours; a diagonal counts only if no 4-path joins the two pixels.
        auto on = [&](int uu, int vv) {
          return uu >= 0 && vv >= 0 && uu < skel.cols && vv < skel.rows && skel.at<uchar>(vv, uu);
        };
        double l = 0;
        if (on(u + 1, v)) l += 1;
        if (on(u, v + 1)) l += 1;
        if (on(u + 1, v + 1) && !on(u + 1, v) && !on(u, v + 1)) l += std::sqrt(2.0);
        if (on(u - 1, v + 1) && !on(u - 1, v) && !on(u, v + 1)) l += std::sqrt(2.0);
        len_px += l;
        len_m += l * ps;
      }
    if (nskel == 0) continue;
    {  // the pruning shortened each remaining branch end by spur_px
      const double add_px = double(spur_px) * ends;
      len_m += add_px * len_m / std::max(len_px, 1.0);
      len_px += add_px;
    }
    if (!(len_px > 0)) continue;
    // Width from the darkness profile, not the mask: the contrast summed over the component per
    // unit length / the contrast on the skeleton (the profile's area over its height). The mask
    // holds the crack's faint blurred edges too (1 σ above the level), about a pixel too wide.
    double total_contrast = 0;
    for (int v = 0; v < comp.rows; ++v)
      for (int u = 0; u < comp.cols; ++u)
        if (comp.at<uchar>(v, u))
          total_contrast +=
              std::max(0, response.at<uchar>(v + box.y, u + box.x) - level_med.at<uchar>(v + box.y, u + box.x));
    if (skel_contrast > 0) {
      const double profile_w_px = total_contrast / (skel_contrast / nskel) / len_px;
      const double scale = std::clamp(profile_w_px / (wsum_px / nskel), 0.1, 1.0);
      wsum_px *= scale, wsum_m *= scale, wmax_m *= scale;
    }
    const double mean_w_px = wsum_px / nskel;
    if (len_px < o.min_length_px) continue;
    // Elongation on the road where pixel sizes are known (an oblique view foreshortens along
    // the column), else on the image.
    if (metric ? !(len_m * nskel >= o.min_elongation * wsum_m) : len_px / mean_w_px < o.min_elongation) continue;
    if (metric && (!(len_m >= o.min_length_m) || wsum_m / nskel > o.max_width_m)) continue;
    DamageInstance d;
    d.id = ++next;
    d.type = DamageType::kCrack;
    d.pixel_count = cv::countNonZero(comp);
    if (e.probability) {  // the mean learned probability
      d.confidence = std::clamp(cv::mean(response(box), comp)[0] / 255.0, 0.0, 1.0);
    } else {  // mean black-hat contrast relative to twice the detection level above the median
      const double contrast = cv::mean(response(box), comp)[0] - cv::mean(level_med(box), comp)[0];
      const double box_sigma = cv::mean(e.level_sigma(box), comp)[0];
      d.confidence = std::clamp(contrast / (2.0 * e.k_sigma * std::max(1.0, box_sigma)), 0.0, 1.0);
    }
    if (metric) {
      d.length_m = len_m;
      d.mean_width_m = wsum_m / nskel;
      d.max_width_m = wmax_m;
    }
    out.labels(box).setTo(d.id, comp);
    d.outline_px = OutlineOf(out.labels, d.id, box);
    out.instances.push_back(std::move(d));
  }
}

}  // namespace

CrackOptions::Detector ResolveCrackDetector(const CrackOptions& o, bool calibrated, cv::Size size) {
  using D = CrackOptions::Detector;
  if (o.detector != D::kAuto) return o.detector;
  // With pixel sizes the metric black-hat stays the default: on the simulator's frames it
  // measured better than the model trained on patches (docs/results/damage.md); so does the
  // ridge on whole frames in pixel units.
  if (calibrated || std::max(size.width, size.height) > kAutoLearnedMaxSidePx) return D::kRidge;
  return std::filesystem::exists(ResolveCrackModelPath(o.model)) ? D::kLearned : D::kRidge;
}

const char* CrackDetectorName(CrackOptions::Detector d, bool calibrated) {
  using D = CrackOptions::Detector;
  switch (d) {
    case D::kAuto: return "auto";
    case D::kLearned: return "learned";
    case D::kRidge: return calibrated ? "black-hat" : "ridge";  // the ridge runs in pixel units only
    case D::kBlackHat: return "black-hat";
  }
  return "?";
}

cv::Mat CrackResponse(const cv::Mat& image, const CrackOptions& o, const cv::Mat& pixel_size_m) {
  const cv::Mat grey = Grey(image);
  if (!pixel_size_m.empty() && (pixel_size_m.size() != grey.size() || pixel_size_m.type() != CV_32FC1))
    throw std::invalid_argument("CrackResponse: pixel sizes must be CV_32F of the image's size");
  if (ResolveCrackDetector(o, !pixel_size_m.empty(), grey.size()) == CrackOptions::Detector::kLearned) {
    cv::Mat p8;
    CrackProbability(grey, ResolveCrackModelPath(o.model)).convertTo(p8, CV_8U, 255.0);
    return p8;
  }
  return ResponseOfGrey(grey, pixel_size_m, o);
}

CrackDetection DetectCracks(const cv::Mat& image, const cv::Mat& road_mask, const cv::Mat& exclude,
                            const cv::Mat& pixel_size_m, const CrackOptions& o, const cv::Mat& precomputed) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw std::invalid_argument("DetectCracks: image must be 8-bit grey or BGR");
  if (!precomputed.empty() && (precomputed.size() != image.size() || precomputed.type() != CV_8UC1))
    throw std::invalid_argument("DetectCracks: response must be CV_8U of the image's size");
  auto same = [&](const cv::Mat& m, int type) { return m.empty() || (m.size() == image.size() && m.type() == type); };
  if (!same(road_mask, CV_8UC1) || !same(exclude, CV_8UC1) || !same(pixel_size_m, CV_32FC1))
    throw std::invalid_argument("DetectCracks: masks must be CV_8U and pixel sizes CV_32F of the image's size");
  const CrackOptions::Detector detector = ResolveCrackDetector(o, !pixel_size_m.empty(), image.size());
  const cv::Mat response = precomputed.empty() ? CrackResponse(image, o, pixel_size_m) : precomputed;
  cv::Mat search = road_mask.empty() ? cv::Mat(image.size(), CV_8U, cv::Scalar(255)) : (road_mask != 0);
  if (!exclude.empty()) search &= (exclude == 0);

  CrackDetection out;
  out.detector = detector;
  out.labels = cv::Mat::zeros(image.size(), CV_16U);
  if (detector == CrackOptions::Detector::kLearned) {
    // The probability (× 255) at the model's threshold; its level is zero.
    const CrackModelInfo& model = LoadCrackModel(ResolveCrackModelPath(o.model));
    out.response_threshold = o.learned_threshold > 0 ? o.learned_threshold : model.threshold;
    const cv::Mat cand = (response >= std::ceil(out.response_threshold * 255.0 - 1e-6)) & search;
    const cv::Mat zero = cv::Mat::zeros(image.size(), CV_8U);
    CrackOptions rules = o;  // the model's own component rules, where it carries them
    if (model.min_length_px > 0) rules.min_length_px = model.min_length_px;
    if (model.min_elongation > 0) rules.min_elongation = model.min_elongation;
    MeasureComponents(cand, {response, zero, zero, 1.0, true}, pixel_size_m, rules, out);
    return out;
  }
  // Robust level of the texture response (median + k·1.4826·MAD over the searched road), per
  // cell: the coarse aggregate resolved near an oblique camera responds far more than the
  // blurred road farther away, which one level per frame let through as "cracks".
  std::vector<uchar> vals = SearchedSamples(response, search);
  double med = 0, sigma = 1;
  if (!RobustLevel(vals, &med, &sigma)) return out;
  out.response_threshold = med + o.k_sigma * sigma;
  const cv::Mat grid = LocalLevelGrid(response, search, o, med, sigma);
  const cv::Mat level_med = LevelMap(grid, 1, 0, image.size()), level_sigma = LevelMap(grid, 0, 1, image.size());

  cv::Mat cand;
  if (detector == CrackOptions::Detector::kRidge && pixel_size_m.empty()) {
    std::vector<double> sigmas;
    for (double s = o.ridge_min_sigma_px; s <= o.ridge_max_sigma_px * 1.001; s *= std::sqrt(2.0)) sigmas.push_back(s);
    cv::Mat best_sigma;
    const cv::Mat strength = RidgeStrength(Grey(image), search, sigmas, &best_sigma);
    const int window = 2 * int(std::lround(2 * sigmas.back())) + 1;
    const double searched = cv::countNonZero(search);
    const double p_low = cv::countNonZero((strength > o.ridge_low_sigma) & search) / std::max(1.0, searched);
    const cv::Mat seeded = Hysteresis(strength, search, o.ridge_low_sigma, o.ridge_high_sigma);
    cand = CrackRegion(MeaningfulComponents(seeded, best_sigma, p_low, searched), best_sigma,
                       Darkness(Grey(image), window), o.ridge_width_factor) &
           search;
  } else if (o.line_length_px > 0) {
    // Pixels darker than their surroundings (response above the local median + 1 σ) where the
    // line support stands out (its own local level + k σ).
    const cv::Mat support = LineSupport(response, o.line_length_px);
    std::vector<uchar> svals = SearchedSamples(support, search);
    double smed = 0, ssigma = 1;
    RobustLevel(svals, &smed, &ssigma);
    const cv::Mat sgrid = LocalLevelGrid(support, search, o, smed, ssigma);
    // Seeds: the pixel's response 1 σ above its level and the line support k σ above its own;
    // grown through connected pixels where both stand line_grow_sigma above their levels.
    const cv::Mat seeds = (response > LevelMap(grid, 1, 1, image.size())) & search &
                          (support > LevelMap(sgrid, 1, o.k_sigma, image.size()));
    const cv::Mat grow = (response > LevelMap(grid, 1, o.line_grow_sigma, image.size())) & search &
                         (support > LevelMap(sgrid, 1, o.line_grow_sigma, image.size()));
    cand = ComponentsWithSeeds(grow | seeds, seeds);
  } else {
    cand = (response > LevelMap(grid, 1, o.k_sigma, image.size())) & search;
  }
  MeasureComponents(cand, {response, level_med, level_sigma, o.k_sigma, false}, pixel_size_m, o, out);
  return out;
}

}  // namespace rs
