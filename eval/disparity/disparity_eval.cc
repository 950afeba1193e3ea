#include "eval/disparity/disparity_eval.h"

#include <cmath>
#include <fstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "formats/input_error.h"

namespace rs {

DisparityMetrics EvaluateDisparity(const cv::Mat& est, const cv::Mat& est_valid, const cv::Mat& gt,
                                   const cv::Mat& region) {
  if (est.type() != CV_32F || gt.type() != CV_32F || est_valid.type() != CV_8U || est.size() != gt.size() ||
      est_valid.size() != gt.size() || (!region.empty() && (region.type() != CV_8U || region.size() != gt.size())))
    throw std::invalid_argument("eval: need CV_32F est/gt, CV_8U valid/region, equal sizes");
  DisparityMetrics m;
  int64_t n_valid = 0, b1 = 0, b2 = 0, b3 = 0, d1 = 0;
  double sum = 0;
  for (int v = 0; v < gt.rows; ++v)
    for (int u = 0; u < gt.cols; ++u) {
      const float g = gt.at<float>(v, u);
      if (!(g > 0) || (!region.empty() && !region.at<uint8_t>(v, u))) continue;
      ++m.evaluated;
      if (!est_valid.at<uint8_t>(v, u)) continue;
      ++n_valid;
      const double e = std::abs(double(est.at<float>(v, u)) - g);
      sum += e;
      b1 += e > 1, b2 += e > 2, b3 += e > 3, d1 += e > 3 && e > 0.05 * g;
    }
  if (m.evaluated == 0) return m;
  const double n = double(m.evaluated), inv = double(m.evaluated - n_valid);
  m.density = n_valid / n;
  m.bad1 = (b1 + inv) / n, m.bad2 = (b2 + inv) / n, m.bad3 = (b3 + inv) / n, m.d1 = (d1 + inv) / n;
  if (n_valid > 0) {
    const double k = double(n_valid);
    m.bad1_est = b1 / k, m.bad2_est = b2 / k, m.bad3_est = b3 / k, m.d1_est = d1 / k, m.epe = sum / k;
  }
  return m;
}

cv::Mat NonOccludedMask(const cv::Mat& gl, const cv::Mat& gr, double tol) {
  cv::Mat m = cv::Mat::zeros(gl.size(), CV_8U);
  for (int v = 0; v < gl.rows; ++v)
    for (int u = 0; u < gl.cols; ++u) {
      const float d = gl.at<float>(v, u);
      if (!(d > 0)) continue;
      const int x = static_cast<int>(std::lround(u - d));
      if (x < 0 || x >= gr.cols) continue;
      const float dr = gr.at<float>(v, x);
      if (dr > 0 && std::abs(dr - d) <= tol) m.at<uint8_t>(v, u) = 255;
    }
  return m;
}

namespace {

cv::Mat Read(const std::string& path, int flags) {
  std::ifstream probe(path);
  if (!probe) throw InputError(InputLocation::File(path), "cannot open file");
  cv::Mat m = cv::imread(path, flags);
  if (m.empty()) throw InputError(InputLocation::File(path), "cannot decode image");
  return m;
}

}  // namespace

std::vector<StereoPairWithTruth> LoadMiddlebury(const std::string& root) {
  struct Spec {
    const char *name, *l, *r, *dl, *dr;
    double scale;
    int range;
  };
  const Spec specs[] = {
      {"Cloth3", "view1.png", "view5.png", "disp1.png", "disp5.png", 2.0, 128},
      {"Reindeer", "view1.png", "view5.png", "disp1.png", "disp5.png", 2.0, 128},
      {"Wood2", "view1.png", "view5.png", "disp1.png", "disp5.png", 2.0, 128},
      {"cone", "im2.png", "im6.png", "disp2.png", "disp6.png", 4.0, 64},
  };
  std::vector<StereoPairWithTruth> out;
  for (const Spec& s : specs) {
    const std::string dir = root + "/Data/" + s.name + "/";
    StereoPairWithTruth p;
    p.name = s.name;
    p.left = Read(dir + s.l, cv::IMREAD_GRAYSCALE);
    p.right = Read(dir + s.r, cv::IMREAD_GRAYSCALE);
    cv::Mat gl = Read(dir + s.dl, cv::IMREAD_GRAYSCALE), gr = Read(dir + s.dr, cv::IMREAD_GRAYSCALE);
    if (gl.size() != p.left.size() || gr.size() != p.left.size() || p.right.size() != p.left.size())
      throw InputError(InputLocation::File(dir), "image and disparity sizes differ");
    gl.convertTo(p.gt, CV_32F, 1.0 / s.scale);
    cv::Mat gtr;
    gr.convertTo(gtr, CV_32F, 1.0 / s.scale);
    p.nonocc = NonOccludedMask(p.gt, gtr);
    p.min_disparity = 0;
    p.num_disparities = s.range;
    out.push_back(std::move(p));
  }
  return out;
}

DisparityMetrics PoolMetrics(const std::vector<DisparityMetrics>& parts) {
  DisparityMetrics t;
  double n_valid = 0;
  for (const auto& m : parts) {
    const double n = double(m.evaluated), k = m.density * n;
    t.evaluated += m.evaluated, n_valid += k;
    t.bad1 += m.bad1 * n, t.bad2 += m.bad2 * n, t.bad3 += m.bad3 * n, t.d1 += m.d1 * n;
    t.bad1_est += m.bad1_est * k, t.bad2_est += m.bad2_est * k, t.bad3_est += m.bad3_est * k;
    t.d1_est += m.d1_est * k, t.epe += m.epe * k;
  }
  if (t.evaluated == 0) return DisparityMetrics{};
  const double n = double(t.evaluated);
  t.density = n_valid / n;
  t.bad1 /= n, t.bad2 /= n, t.bad3 /= n, t.d1 /= n;
  if (n_valid > 0)
    t.bad1_est /= n_valid, t.bad2_est /= n_valid, t.bad3_est /= n_valid, t.d1_est /= n_valid, t.epe /= n_valid;
  return t;
}

}  // namespace rs
