#include "sim/synthetic_damage_scene.h"

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>

namespace rs {
namespace {

// A spherical-cap pothole: rim circle (centre on the plane, radius a) and the sphere below it.
struct Bowl {
  Eigen::Vector3d centre, sphere;
  double a = 0, R = 0;
};

// The scene in the camera frame: road normal `up` (towards the camera), in-plane axes e1
// (camera x) and e2 (along the road, away from the camera), the first pothole's centre c0.
struct SceneFrame {
  Eigen::Vector3d up, e1, e2, c0;
  std::vector<Bowl> bowls;
};

Bowl MakeBowl(const SceneFrame& f, const Eigen::Vector3d& centre, double a, double h) {
  const double R = (a * a + h * h) / (2 * h);
  return {centre, centre + f.up * (R - h), a, R};
}

SceneFrame Frame(const SyntheticRoadScene& s) {
  SceneFrame f;
  const double th = s.pitch_deg * CV_PI / 180.0;
  f.up = Eigen::Vector3d(0, -std::cos(th), -std::sin(th));
  // First pothole: on the plane, straight ahead in the image's centre column at depth pothole_z_m.
  // Ray through (cx, v): z = 1, y = (v − cy)/f; solve up·(Z r) = −H for the row that gives Z.
  const double yz = (-s.height_m / s.pothole_z_m - f.up.z()) / f.up.y();
  f.c0 = s.pothole_z_m * Eigen::Vector3d(0, yz, 1);
  f.e1 = Eigen::Vector3d::UnitX();
  f.e2 = f.up.cross(f.e1);
  f.bowls.push_back(MakeBowl(f, f.c0, s.pothole_radius_m, s.pothole_depth_m));
  for (const SyntheticPothole& p : s.more_potholes)
    f.bowls.push_back(MakeBowl(f, f.c0 + p.across_m * f.e1 + p.along_m * f.e2, p.radius_m, p.depth_m));
  return f;
}

// Camera depth Z of the scene along ray r (NaN above the horizon); `bowl` = index of the
// pothole hit or −1.
double SceneDepth(const SyntheticRoadScene& s, const SceneFrame& f, const Eigen::Vector3d& r, int& bowl) {
  bowl = -1;
  const double ur = f.up.dot(r);
  if (ur >= -1e-9) return std::numeric_limits<double>::quiet_NaN();  // above the horizon: no road
  const double z_road = -s.height_m / ur;
  if (s.box_height_m > 0) {  // slab top at box_height_m, to the right of the first pothole, 0.6 m × 0.6 m
    const double zt = -(s.height_m - s.box_height_m) / ur;
    const Eigen::Vector3d q = zt * r - f.c0;
    const double a = f.e1.dot(q), b = f.e2.dot(q);
    if (a > 0.45 && a < 1.05 && b > -0.3 && b < 0.3) return zt;
  }
  const Eigen::Vector3d p = z_road * r;
  for (size_t i = 0; i < f.bowls.size(); ++i) {
    const Bowl& w = f.bowls[i];
    if ((p - w.centre).norm() >= w.a) continue;
    // Far intersection of the ray with the sphere = the bowl's surface below the plane.
    const double b = r.dot(w.sphere), cc = w.sphere.squaredNorm() - w.R * w.R, rr = r.squaredNorm();
    const double disc = b * b - rr * cc;
    if (disc > 0) {
      bowl = static_cast<int>(i);
      return (b + std::sqrt(disc)) / rr;
    }
  }
  return z_road;
}

Eigen::Vector3d Ray(const RectifiedStereo& g, int u, int v) {
  return {(u - g.cx_px) / g.f_px, (v - g.cy_px) / g.f_px, 1.0};
}

}  // namespace

cv::Mat SyntheticRoadScene::Render() const {
  const SceneFrame f = Frame(*this);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_d_px);
  cv::Mat d(height, width, CV_32F);
  const double fb = geometry.f_px * geometry.baseline_m;
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      int bowl = 0;
      const double z = SceneDepth(*this, f, Ray(geometry, u, v), bowl);
      d.at<float>(v, u) = std::isfinite(z) ? static_cast<float>(fb / z + noise(rng)) : 0.0f;
    }
  if (invalid_fraction > 0) {  // separate generator: the noise above does not depend on it
    std::mt19937 blocks(seed + 1);
    std::bernoulli_distribution drop(invalid_fraction);
    for (int v = 0; v < height; v += 8)
      for (int u = 0; u < width; u += 8)
        if (drop(blocks)) d(cv::Rect(u, v, 8, 8) & cv::Rect(0, 0, width, height)).setTo(0);
  }
  return d;
}

cv::Mat SyntheticRoadScene::RenderImage() const {
  const SceneFrame f = Frame(*this);
  // Asphalt: fine-grained noise around mid grey; pothole floors darker, sky bright.
  cv::Mat tex(height, width, CV_32F);
  cv::RNG rng(seed + 7);
  rng.fill(tex, cv::RNG::NORMAL, 0.0, 14.0);
  cv::GaussianBlur(tex, tex, {0, 0}, 1.0);
  cv::Mat img(height, width, CV_8U);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d r = Ray(geometry, u, v);
      int bowl = 0;
      const double z = SceneDepth(*this, f, r, bowl);
      double g = 118.0 + tex.at<float>(v, u);
      if (!std::isfinite(z))
        g = 200.0;
      else if (bowl >= 0)
        g -= 30.0;
      else {
        // Lane marking: a 0.12 m white stripe along the road, 1.1 m left of the first pothole.
        const double a = f.e1.dot(z * r - f.c0);
        if (a > -1.22 && a < -1.1) g = 225.0 + 0.3 * tex.at<float>(v, u);
      }
      img.at<uchar>(v, u) = cv::saturate_cast<uchar>(g);
    }
  // Cracks: random walks of 10 segments, 2–4 px wide.
  std::mt19937 walk(seed + 11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < cracks; ++k) {
    cv::Point2d p(width * (0.1 + 0.8 * unit(walk)), height * (0.35 + 0.6 * unit(walk)));
    double dir = 2 * CV_PI * unit(walk);
    const double step = (15.0 + 30.0 * unit(walk)) * width / 1280.0;
    std::vector<cv::Point> line{p};
    for (int i = 0; i < 10; ++i) {
      dir += 0.8 * (unit(walk) - 0.5);
      p += step * cv::Point2d(std::cos(dir), std::sin(dir));
      line.emplace_back(p);
    }
    const int w = 2 + static_cast<int>(3 * unit(walk)) % 3;
    cv::polylines(img, std::vector<std::vector<cv::Point>>{line}, false, cv::Scalar(50), w, cv::LINE_8);
  }
  return img;
}

double SyntheticRoadScene::TrueAreaM2() const { return CV_PI * pothole_radius_m * pothole_radius_m; }

double SyntheticRoadScene::TrueVolumeM3() const {
  const double a = pothole_radius_m, h = pothole_depth_m, R = (a * a + h * h) / (2 * h);
  return CV_PI * h * h * (3 * R - h) / 3.0;
}

SyntheticRoadScene BenchmarkRoadScene(int width, int height) {
  SyntheticRoadScene s;
  s.width = width, s.height = height;
  s.geometry = {width * 0.78, width / 2.0, height / 2.0, 0.20};
  s.more_potholes = {
      {-0.75, -0.3, 0.12, 0.035}, {0.1, -0.7, 0.2, 0.03}, {-0.6, 0.55, 0.15, 0.05}, {0.7, 0.75, 0.4, 0.025}};
  s.box_height_m = 0.4;
  s.sigma_d_px = 0.15;
  s.invalid_fraction = 0.02;
  s.cracks = 6;
  return s;
}

}  // namespace rs
