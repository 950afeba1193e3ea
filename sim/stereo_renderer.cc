#include "sim/stereo_renderer.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "sim/sim_random.h"

namespace rs::sim {
namespace {
constexpr double kDeg = 3.14159265358979323846 / 180.0;
}

StereoCalibration MakeCalibration(const SimulationOptions& o) {
  StereoCalibration c;
  CameraIntrinsics K;
  K.width = o.image_width;
  K.height = o.image_height;
  K.fx = K.fy = o.focal_px;
  K.cx = o.cx_px >= 0 ? o.cx_px : (o.image_width - 1) / 2.0;
  K.cy = o.cy_px >= 0 ? o.cy_px : (o.image_height - 1) / 2.0;
  c.left = c.right = K;
  c.rectified = o.rectified;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (!o.rectified) {
    c.left.dist = {o.k1, o.k2, o.p1, o.p2, 0.0};
    c.right.dist = {o.k1 * 1.05, o.k2 * 0.95, -o.p1, o.p2 * 0.8, 0.0};
    c.right.fx = c.right.fy = o.focal_px * 1.004;
    c.right.cx += 3.5;
    c.right.cy -= 2.0;
    const double a = o.raw_right_rotation_deg * kDeg;
    R = (Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()))
            .toRotationMatrix();
  }
  const Eigen::Vector3d t = -R * Eigen::Vector3d(o.baseline_m, 0, 0);
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) c.R_right_left[r * 3 + k] = R(r, k);
    c.t_right_left[r] = t[r];
  }
  return c;
}

StereoRenderer::StereoRenderer(const RoadScene& scene, const SimulationOptions& o, const StereoCalibration& calib)
    : scene_(scene), o_(o) {
  cams_[0] = MakeCamera(calib.left, !calib.rectified, 1.0);
  cams_[1] = MakeCamera(calib.right, !calib.rectified, o.right_gain);
  Eigen::Matrix3d R_rl;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) R_rl(r, k) = calib.R_right_left[r * 3 + k];
  const Eigen::Vector3d t_rl(calib.t_right_left[0], calib.t_right_left[1], calib.t_right_left[2]);
  // p_right = R p_left + t  =>  T_left_right = (R^T, -R^T t)
  cams_[1].T_left_cam.linear() = R_rl.transpose();
  cams_[1].T_left_cam.translation() = -R_rl.transpose() * t_rl;
}

StereoRenderer::Camera StereoRenderer::MakeCamera(const CameraIntrinsics& K, bool distorted, double gain) const {
  Camera c;
  c.width = K.width;
  c.height = K.height;
  c.gain = gain;
  const size_t n = static_cast<size_t>(K.width) * K.height;
  c.rays.resize(n);
  c.vignette.resize(n);
  std::vector<cv::Point2f> px(n), und;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) px[static_cast<size_t>(v) * K.width + u] = cv::Point2f(u, v);
  if (distorted) {
    const cv::Matx33d Km(K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
    const std::vector<double> D(K.dist.begin(), K.dist.end());
    cv::undistortPoints(px, und, Km, D, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-10));
  }
  const double r_max2 = (K.cx * K.cx + K.cy * K.cy) / (K.fx * K.fx);
  // Normalised image coordinates (x, y) of each pixel: the ray is (x, y, 1) / |(x, y, 1)|.
  auto xy = [&](size_t i) {
    if (distorted) return Eigen::Vector2d(und[i].x, und[i].y);
    return Eigen::Vector2d((px[i].x - K.cx) / K.fx, (px[i].y - K.cy) / K.fy);
  };
  c.ray_diff.resize(n);
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      const size_t i = static_cast<size_t>(v) * K.width + u;
      const Eigen::Vector2d p = xy(i);
      const double x = p.x(), y = p.y();
      c.rays[i] = Eigen::Vector3f(x, y, 1).normalized();
      c.vignette[i] = static_cast<float>(1.0 - o_.vignetting * std::min(1.0, (x * x + y * y) / r_max2));
      // Ray differentials: d(x, y)/du and /dv by central differences (one-sided at the border; exact for the
      // pinhole, the undistortion's Jacobian for the raw camera), times 1 / |(x, y, 1)|: the change of the
      // unit ray up to its component along itself, which the footprint does not depend on.
      const int u0 = std::max(u - 1, 0), u1 = std::min(u + 1, K.width - 1);
      const int v0 = std::max(v - 1, 0), v1 = std::min(v + 1, K.height - 1);
      const size_t row = static_cast<size_t>(v) * K.width;
      const Eigen::Vector2d du = (xy(row + u1) - xy(row + u0)) / (u1 - u0);
      const Eigen::Vector2d dv =
          (xy(static_cast<size_t>(v1) * K.width + u) - xy(static_cast<size_t>(v0) * K.width + u)) / (v1 - v0);
      const double k = 1.0 / std::sqrt(x * x + y * y + 1);
      c.ray_diff[i] = Eigen::Vector4f(du.x() * k, du.y() * k, dv.x() * k, dv.y() * k);
    }
  }
  return c;
}

void StereoRenderer::Render(const std::vector<Eigen::Isometry3d>& T_world_left, int cam, uint64_t frame_key,
                            bool with_truth, RenderedView* out) const {
  const Camera& c = cams_[cam];
  out->gray.create(c.height, c.width, CV_8UC1);
  if (with_truth) {
    out->depth_m.create(c.height, c.width, CV_32FC1);
    out->label.create(c.height, c.width, CV_16UC1);
  }
  std::vector<Eigen::Isometry3d> T_world_cam;
  for (const auto& T : T_world_left) T_world_cam.push_back(T * c.T_left_cam);
  const size_t mid = T_world_cam.size() / 2;
  const float inv_samples = 1.0f / static_cast<float>(T_world_cam.size());
  const double noise = o_.noise_sigma_dn;
  const uint64_t key = HashCombine(frame_key, static_cast<uint64_t>(cam) + 1);
  std::vector<double> z_start;  // smooth road height under each pose: where every ray's search starts
  for (const auto& T : T_world_cam) {
    double s, l;
    scene_.road().ToRoad(T.translation().x(), T.translation().y(), &s, &l);
    z_start.push_back(scene_.road().SmoothZ(s, l));
  }

  tbb::parallel_for(tbb::blocked_range<int>(0, c.height, 4), [&](const tbb::blocked_range<int>& rows) {
    // Latest road hit in this row per pose: its tangent plane starts this pixel's
    // search (sky and obstacle hits leave it). Reset per row, so the result does
    // not depend on how rows are split between threads.
    std::vector<RayHit> prev(T_world_cam.size());
    for (int v = rows.begin(); v < rows.end(); ++v) {
      uint8_t* g = out->gray.ptr<uint8_t>(v);
      float* dep = with_truth ? out->depth_m.ptr<float>(v) : nullptr;
      uint16_t* lab = with_truth ? out->label.ptr<uint16_t>(v) : nullptr;
      for (auto& h : prev) h = RayHit();
      for (int u = 0; u < c.width; ++u) {
        const size_t i = static_cast<size_t>(v) * c.width + u;
        const Eigen::Vector3d ray_cam = c.rays[i].cast<double>();
        const Eigen::Vector4d j = c.ray_diff[i].cast<double>();
        float radiance = 0;
        for (size_t k = 0; k < T_world_cam.size(); ++k) {
          const Eigen::Matrix3d& R = T_world_cam[k].linear();
          const Eigen::Vector3d d = R * ray_cam;
          const Eigen::Vector3d& o = T_world_cam[k].translation();
          const PixelDifferentials px{R.col(0) * j[0] + R.col(1) * j[1], R.col(0) * j[2] + R.col(1) * j[3]};
          const RayHit h = scene_.Cast(o, d, px, z_start[k], prev[k].StartOnPlane(o, d));
          if (h.road) prev[k] = h;
          radiance += h.hit ? h.radiance : 0.9f - 0.2f * static_cast<float>(d.z());  // sky
          if (k == mid && with_truth) {
            dep[u] = h.hit ? static_cast<float>(h.t * ray_cam.z()) : 0.0f;
            lab[u] = h.label;
          }
        }
        double dn = 255.0 * radiance * inv_samples * c.gain * c.vignette[i];
        if (noise > 0) {
          // Irwin-Hall sum of 4 uniforms from one hash: cheap, near-Gaussian, unit variance.
          const uint64_t hsh = HashCombine(key, i);
          const double sum = static_cast<double>(hsh & 0xFFFF) + static_cast<double>((hsh >> 16) & 0xFFFF) +
                             static_cast<double>((hsh >> 32) & 0xFFFF) + static_cast<double>(hsh >> 48);
          dn += noise * (sum / 65535.0 - 2.0) * 1.7320508075688772;
        }
        // Round half up (lround for dn >= 0) without a libm call per pixel.
        g[u] = static_cast<uint8_t>(std::clamp(static_cast<int>(std::floor(dn + 0.5)), 0, 255));
      }
    }
  });
}

}  // namespace rs::sim
