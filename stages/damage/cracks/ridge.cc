#include "stages/damage/cracks/ridge.h"

#include "survey/stats/order_statistic.h"
#include "survey/stats/robust_stats.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include <algorithm>
#include <cmath>

namespace rs {

namespace {

// Signed ridge measure at one scale (see RidgeStrength).
cv::Mat RidgeAtScale(const cv::Mat& grey32, double sigma) {
  cv::Mat g, dxx, dyy, dxy, gx, gy;
  cv::GaussianBlur(grey32, g, {0, 0}, sigma, sigma, cv::BORDER_REFLECT);
  const cv::Mat kxx = (cv::Mat_<float>(1, 3) << 1, -2, 1);
  const cv::Mat kd = (cv::Mat_<float>(1, 3) << -0.5f, 0, 0.5f);
  const cv::Mat kxy = (cv::Mat_<float>(3, 3) << 0.25f, 0, -0.25f, 0, 0, 0, -0.25f, 0, 0.25f);
  cv::filter2D(g, dxx, CV_32F, kxx, {-1, -1}, 0, cv::BORDER_REFLECT);
  cv::filter2D(g, dyy, CV_32F, kxx.t(), {-1, -1}, 0, cv::BORDER_REFLECT);
  cv::filter2D(g, dxy, CV_32F, kxy, {-1, -1}, 0, cv::BORDER_REFLECT);
  cv::filter2D(g, gx, CV_32F, kd, {-1, -1}, 0, cv::BORDER_REFLECT);
  cv::filter2D(g, gy, CV_32F, kd.t(), {-1, -1}, 0, cv::BORDER_REFLECT);
  cv::Mat s(grey32.size(), CV_32F);
  const float s2 = float(sigma * sigma), s1 = float(sigma);
  for (int v = 0; v < s.rows; ++v) {
    const float *a = dxx.ptr<float>(v), *b = dyy.ptr<float>(v), *c = dxy.ptr<float>(v);
    const float *px = gx.ptr<float>(v), *py = gy.ptr<float>(v);
    float* out = s.ptr<float>(v);
    for (int u = 0; u < s.cols; ++u) {
      const float mean = 0.5f * (a[u] + b[u]);
      const float r = std::sqrt(0.25f * (a[u] - b[u]) * (a[u] - b[u]) + c[u] * c[u]);
      const float l1 = mean + r, l2 = mean - r;
      out[u] = s2 * (l1 - std::max(l2, 0.0f)) - s1 * std::sqrt(px[u] * px[u] + py[u] * py[u]);
    }
  }
  return s;
}

// Median and robust σ of `m` over the searched pixels (every 2nd row and column); σ at least
// `min_sigma` (a flat synthetic image has none).
void RobustLevel(const cv::Mat& m, const cv::Mat& search, double min_sigma, double* med, double* sigma) {
  std::vector<float> vals;
  for (int v = 0; v < m.rows; v += 2)
    for (int u = 0; u < m.cols; u += 2)
      if (search.empty() || search.at<uchar>(v, u)) vals.push_back(m.at<float>(v, u));
  if (vals.size() < 16) {
    *med = 0, *sigma = min_sigma;
    return;
  }
  *med = LowerMedianInPlace(vals);
  for (float& x : vals) x = std::abs(x - float(*med));
  *sigma = std::max(min_sigma, SigmaOfMedianAbs(LowerMedianInPlace(vals)));
}

}  // namespace

cv::Mat RidgeStrength(const cv::Mat& grey, const cv::Mat& search, const std::vector<double>& sigmas_px,
                      cv::Mat* best_sigma) {
  cv::Mat grey32;
  grey.convertTo(grey32, CV_32F);
  cv::Mat best(grey.size(), CV_32F, cv::Scalar(-1e9));
  cv::Mat best_raw(grey.size(), CV_32F, cv::Scalar(-1e9));
  if (best_sigma) *best_sigma = cv::Mat(grey.size(), CV_32F, cv::Scalar(sigmas_px.empty() ? 0.0 : sigmas_px[0]));
  for (const double sigma : sigmas_px) {
    const cv::Mat s = RidgeAtScale(grey32, sigma);
    double med = 0, sd = 1;
    // Floor: a tenth of a grey level (8-bit quantisation alone gives ~0.3).
    RobustLevel(s, search, 0.1, &med, &sd);
    best = cv::max(best, (s - med) / sd);
    // Width from the raw scale-normalised response (its peak over σ is at half the line's
    // width), not the texture-normalised one (whose texture level differs per scale).
    if (best_sigma) best_sigma->setTo(sigma, s > best_raw);
    best_raw = cv::max(best_raw, s);
  }
  return best;
}

cv::Mat Hysteresis(const cv::Mat& strength, const cv::Mat& search, double low, double high) {
  cv::Mat weak = strength > low;
  if (!search.empty()) weak &= search != 0;
  return ComponentsWithSeeds(weak, strength > high);
}

cv::Mat ComponentsWithSeeds(const cv::Mat& weak, const cv::Mat& seeds) {
  cv::Mat labels;
  const int n = cv::connectedComponents(weak != 0, labels, 8, CV_32S);
  std::vector<uchar> seeded(n, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    const uchar* s = seeds.ptr<uchar>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (l[u] && s[u]) seeded[l[u]] = 1;
  }
  cv::Mat out = cv::Mat::zeros(weak.size(), CV_8U);
  for (int v = 0; v < labels.rows; ++v) {
    const int* l = labels.ptr<int>(v);
    uchar* o = out.ptr<uchar>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (l[u] && seeded[l[u]]) o[u] = 255;
  }
  return out;
}

cv::Mat MeaningfulComponents(const cv::Mat& mask, const cv::Mat& best_sigma, double p_low, double searched_px) {
  cv::Mat out = cv::Mat::zeros(mask.size(), CV_8U);
  if (!(p_low > 0 && p_low < 1) || searched_px < 1) return out;
  cv::Mat skel, labels;
  cv::ximgproc::thinning(mask, skel, cv::ximgproc::THINNING_ZHANGSUEN);
  const int n = cv::connectedComponents(mask, labels, 8, CV_32S);
  std::vector<std::vector<float>> sigmas(n);
  for (int v = 0; v < mask.rows; ++v)
    for (int u = 0; u < mask.cols; ++u)
      if (skel.at<uchar>(v, u)) sigmas[labels.at<int>(v, u)].push_back(best_sigma.at<float>(v, u));
  const double samples_needed = std::log(searched_px) / -std::log(p_low);
  std::vector<uchar> keep(n, 0);
  for (int i = 1; i < n; ++i) {
    if (sigmas[i].empty()) continue;
    const double length = double(sigmas[i].size());  // skeleton pixels ≈ length
    const double sigma = LowerMedianInPlace(sigmas[i]);
    keep[i] = length / (2 * sigma) > samples_needed;
  }
  for (int v = 0; v < mask.rows; ++v)
    for (int u = 0; u < mask.cols; ++u)
      if (keep[labels.at<int>(v, u)]) out.at<uchar>(v, u) = 255;
  return out;
}

cv::Mat CrackRegion(const cv::Mat& mask, const cv::Mat& best_sigma, const cv::Mat& darkness, double disc_factor) {
  cv::Mat skel;
  cv::ximgproc::thinning(mask, skel, cv::ximgproc::THINNING_ZHANGSUEN);
  std::vector<cv::Point> pts;
  cv::findNonZero(skel, pts);
  if (pts.empty()) return skel;
  cv::Mat dist, nearest;  // distance to and label of the nearest skeleton pixel
  cv::distanceTransform(skel == 0, dist, nearest, cv::DIST_L2, cv::DIST_MASK_5, cv::DIST_LABEL_PIXEL);
  // Per label: the skeleton pixel's reach and depth (the darkest pixel of its 3×3: the skeleton
  // may lie a pixel off the profile's bottom).
  cv::Mat deepest;
  cv::dilate(darkness, deepest, cv::Mat());
  std::vector<float> reach(pts.size() + 1, 0), depth(pts.size() + 1, 0);
  for (const cv::Point& p : pts) {
    const int l = nearest.at<int>(p);
    if (l <= 0 || l > int(pts.size())) continue;
    reach[l] = float(std::max(1.0, disc_factor * best_sigma.at<float>(p)));
    depth[l] = deepest.at<float>(p);
  }
  cv::Mat out = skel.clone();
  for (int v = 0; v < out.rows; ++v)
    for (int u = 0; u < out.cols; ++u) {
      const int l = nearest.at<int>(v, u);
      if (l <= 0 || l > int(pts.size())) continue;
      const float d = darkness.at<float>(v, u);
      if (dist.at<float>(v, u) <= reach[l] && d > 0 && d >= 0.5f * depth[l]) out.at<uchar>(v, u) = 255;
    }
  return out;
}

cv::Mat Darkness(const cv::Mat& grey, int window_px) {
  cv::Mat bg, d;
  cv::medianBlur(grey, bg, window_px | 1);
  cv::subtract(bg, grey, d, cv::noArray(), CV_32F);
  return d;
}

}  // namespace rs
