#include "sim/synthetic_road_pair.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace rs {

StereoPairWithTruth MakeSyntheticRoadPair(const SyntheticRoadOptions& o) {
  const int W = o.width, H = o.height, M = 256;
  if (W < 16 || H < 16) throw std::invalid_argument("synthetic road: image too small");
  // Texture: fine and coarse random fields (asphalt-like), wider than the image.
  cv::RNG rng(o.seed);
  cv::Mat fine(H, W + 2 * M, CV_32F), coarse(H, W + 2 * M, CV_32F);
  rng.fill(fine, cv::RNG::UNIFORM, 0.0, 1.0);
  rng.fill(coarse, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(fine, fine, cv::Size(0, 0), 1.0);
  cv::GaussianBlur(coarse, coarse, cv::Size(0, 0), 5.0);
  cv::Mat tex = fine * 1.0 + coarse * 3.0;
  cv::normalize(tex, tex, 20, 235, cv::NORM_MINMAX);

  auto disp = [&](double u, double v) {
    double d = o.c0 + o.cu * u + o.cv * v;
    const double r2 = ((u - o.pothole_u) * (u - o.pothole_u) + (v - o.pothole_v) * (v - o.pothole_v)) /
                      (o.pothole_radius_px * o.pothole_radius_px);
    if (r2 < 1) d -= o.pothole_depth_px * (1 - r2);
    return d;
  };
  StereoPairWithTruth p;
  p.name = "synthetic_road_" + std::to_string(W) + "x" + std::to_string(H);
  p.gt = cv::Mat(H, W, CV_32F);
  p.nonocc = cv::Mat::zeros(H, W, CV_8U);
  p.road = cv::Mat::zeros(H, W, CV_8U);
  cv::Mat map_l(H, W, CV_32FC2), map_r(H, W, CV_32FC2);
  double dmax = 0;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const double d = disp(u, v);
      dmax = std::max(dmax, d);
      p.gt.at<float>(v, u) = static_cast<float>(d);
      const bool visible = u - d >= 0;
      const double r2 = ((u - o.pothole_u) * (u - o.pothole_u) + (v - o.pothole_v) * (v - o.pothole_v)) /
                        (o.pothole_radius_px * o.pothole_radius_px);
      if (visible) p.nonocc.at<uint8_t>(v, u) = 255;
      if (visible && r2 >= 1) p.road.at<uint8_t>(v, u) = 255;
      map_l.at<cv::Vec2f>(v, u) = cv::Vec2f(float(u + M), float(v));
      // Right pixel x sees the surface point with u - d(u) = x: fixed point u = x + d(u).
      double s = u + disp(u, v);
      for (int it = 0; it < 30; ++it) s = u + disp(s, v);
      map_r.at<cv::Vec2f>(v, u) = cv::Vec2f(float(s + M), float(v));
    }
  cv::Mat l, r;
  cv::remap(tex, l, map_l, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::remap(tex, r, map_r, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::Mat nl(H, W, CV_32F), nr(H, W, CV_32F);
  rng.fill(nl, cv::RNG::NORMAL, 0.0, o.noise_sigma);
  rng.fill(nr, cv::RNG::NORMAL, 0.0, o.noise_sigma);
  cv::Mat(l + nl).convertTo(p.left, CV_8U);
  cv::Mat(r + nr).convertTo(p.right, CV_8U);
  p.min_disparity = 0;
  p.num_disparities = (static_cast<int>(std::ceil(dmax)) + 8 + 15) / 16 * 16;
  return p;
}

}  // namespace rs
