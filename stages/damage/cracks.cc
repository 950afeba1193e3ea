#include "stages/damage/cracks.h"

#include "stages/damage/measure.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rs {

namespace {

cv::Mat Grey(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw std::invalid_argument("DetectCracks: image must be 8-bit grey or BGR");
  cv::Mat grey;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else grey = image;
  return grey;
}

cv::Mat ResponseOfGrey(const cv::Mat& grey, const CrackOptions& o) {
  // Multi-scale black-hat: closing fills dark structures narrower than the element.
  cv::Mat response = cv::Mat::zeros(grey.size(), CV_8U), bh;
  for (int k = o.min_scale_px; k <= o.max_scale_px; k += 4) {
    cv::morphologyEx(grey, bh, cv::MORPH_BLACKHAT, cv::getStructuringElement(cv::MORPH_ELLIPSE, {k, k}));
    response = cv::max(response, bh);
  }
  return response;
}

}  // namespace

cv::Mat CrackResponse(const cv::Mat& image, const CrackOptions& o) {
  o.Check();
  return ResponseOfGrey(Grey(image), o);
}

CrackDetection DetectCracks(const cv::Mat& image, const cv::Mat& road_mask, const cv::Mat& exclude,
                            const cv::Mat& pixel_size_m, const CrackOptions& o, const cv::Mat& precomputed) {
  o.Check();
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw std::invalid_argument("DetectCracks: image must be 8-bit grey or BGR");
  if (!precomputed.empty() && (precomputed.size() != image.size() || precomputed.type() != CV_8UC1))
    throw std::invalid_argument("DetectCracks: response must be CV_8U of the image's size");
  auto same = [&](const cv::Mat& m, int type) { return m.empty() || (m.size() == image.size() && m.type() == type); };
  if (!same(road_mask, CV_8UC1) || !same(exclude, CV_8UC1) || !same(pixel_size_m, CV_32FC1))
    throw std::invalid_argument("DetectCracks: masks must be CV_8U and pixel sizes CV_32F of the image's size");
  const cv::Mat response = precomputed.empty() ? ResponseOfGrey(Grey(image), o) : precomputed;
  cv::Mat search = road_mask.empty() ? cv::Mat(image.size(), CV_8U, cv::Scalar(255)) : (road_mask != 0);
  if (!exclude.empty()) search &= (exclude == 0);

  CrackDetection out;
  out.labels = cv::Mat::zeros(image.size(), CV_16U);
  // Robust level of the texture response: median + k·1.4826·MAD over the searched road.
  std::vector<uchar> vals;
  for (int v = 0; v < image.rows; v += 2) {
    const uchar* sr = search.ptr<uchar>(v);
    const uchar* rr = response.ptr<uchar>(v);
    for (int u = 0; u < image.cols; u += 2)
      if (sr[u]) vals.push_back(rr[u]);
  }
  if (vals.size() < 100) return out;
  auto mid = vals.begin() + vals.size() / 2;
  std::nth_element(vals.begin(), mid, vals.end());
  const double med = *mid;
  std::vector<double> dev;
  dev.reserve(vals.size());
  for (uchar x : vals) dev.push_back(std::abs(x - med));
  auto dmid = dev.begin() + dev.size() / 2;
  std::nth_element(dev.begin(), dmid, dev.end());
  const double sigma = std::max(1.0, 1.4826 * *dmid);
  out.response_threshold = med + o.k_sigma * sigma;

  cv::Mat cand = (response > out.response_threshold) & search;
  cv::morphologyEx(cand, cand, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, {3, 3}));
  cv::Mat cc, stats, cent;
  const int n = cv::connectedComponentsWithStats(cand, cc, stats, cent, 8, CV_32S);
  int next = 0;
  for (int i = 1; i < n && next < 65535; ++i) {
    if (std::max(stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT)) < o.min_length_px / 2)
      continue;  // cannot be long enough
    cv::Rect box(stats.at<int>(i, cv::CC_STAT_LEFT) - 1, stats.at<int>(i, cv::CC_STAT_TOP) - 1,
                 stats.at<int>(i, cv::CC_STAT_WIDTH) + 2, stats.at<int>(i, cv::CC_STAT_HEIGHT) + 2);
    box &= cv::Rect({}, image.size());
    const cv::Mat comp = cc(box) == i;
    cv::Mat skel, dist;
    cv::ximgproc::thinning(comp, skel, cv::ximgproc::THINNING_ZHANGSUEN);
    cv::distanceTransform(comp, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    const bool metric = !pixel_size_m.empty();
    double len_px = 0, len_m = 0, wsum_px = 0, wsum_m = 0, wmax_m = 0;
    int nskel = 0;
    for (int v = 0; v < skel.rows; ++v)
      for (int u = 0; u < skel.cols; ++u) {
        if (!skel.at<uchar>(v, u)) continue;
        const double ps = metric ? pixel_size_m.at<float>(v + box.y, u + box.x) : 1.0;
        const double w_px = std::max(1.0, 2.0 * dist.at<float>(v, u) - 1.0);
        ++nskel;
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
    const double mean_w_px = wsum_px / nskel;
    if (len_px < o.min_length_px || len_px / mean_w_px < o.min_elongation) continue;
    if (metric && (!(len_m >= o.min_length_m) || wsum_m / nskel > o.max_width_m)) continue;
    DamageInstance d;
    d.id = ++next;
    d.type = DamageType::kCrack;
    d.pixel_count = cv::countNonZero(comp);
    // Confidence: mean black-hat contrast relative to twice the detection level above the median.
    const double contrast = cv::mean(response(box), comp)[0] - med;
    d.confidence = std::clamp(contrast / (2.0 * o.k_sigma * sigma), 0.0, 1.0);
    if (metric) {
      d.length_m = len_m;
      d.mean_width_m = wsum_m / nskel;
      d.max_width_m = wmax_m;
    }
    out.labels(box).setTo(d.id, comp);
    d.outline_px = OutlineOf(out.labels, d.id, box);
    out.instances.push_back(std::move(d));
  }
  return out;
}

}  // namespace rs
