#include "stages/slam/global_refinement.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace rs {
namespace {

ReprojectionResidual Measurement(double u, double v, double u_right, double scale) {
  return {u, v, u_right, 1000, 1000, 639.5, 359.5, 0.3, 1.0 / scale};
}

// Analytic Jacobians of the (angle-axis, centre) residual against central differences, for a stereo
// observation in both third-row forms and for a mono one.
TEST(GlobalRefinement, JacobiansMatchNumeric) {
  const double pose[6] = {0.3, -0.2, 2.9, 4.0, -120.0, 6.5};  // turned ~170 deg, 120 m from the origin
  const double point[3] = {4.4, -119.5, 0.2};
  for (double u_right : {500.0, -1.0}) {
    for (double sigma_d : {0.0, 0.15}) {
      const ReprojectionResidual r = Measurement(610, 330, u_right, 1.44);
      double res[3], Jp[18], Jx[9];
      EvaluateCentreReprojection(r, sigma_d, pose, point, res, Jp, Jx);
      for (int c = 0; c < 9; ++c) {
        double p[6], x[3], plus[3], minus[3];
        std::copy(pose, pose + 6, p);
        std::copy(point, point + 3, x);
        const double h = 1e-6;
        double* v = c < 6 ? &p[c] : &x[c - 6];
        *v += h;
        EvaluateCentreReprojection(r, sigma_d, p, x, plus, nullptr, nullptr);
        *v -= 2 * h;
        EvaluateCentreReprojection(r, sigma_d, p, x, minus, nullptr, nullptr);
        for (int row = 0; row < 3; ++row) {
          const double numeric = (plus[row] - minus[row]) / (2 * h);
          const double analytic = c < 6 ? Jp[row * 6 + c] : Jx[row * 3 + c - 6];
          EXPECT_NEAR(analytic, numeric, 1e-4 * std::max(1.0, std::abs(numeric)))
              << "u_right " << u_right << " sigma_d " << sigma_d << " row " << row << " column " << c;
        }
      }
    }
  }
}

// A nadir strip over flat ground (the simulator's rig: f 1000 px, B 0.3 m, 6 m up), a keyframe every
// 4th frame, frames matching the keyframes' points. The initial guess is bent the way a drifting front
// end bends it: every camera tilted by a pitch that grows to 3 deg mid-strip, moved along the tilted
// path, the points made from the bent keyframes' stereo. The refinement (both forms of the stereo
// residual) must straighten it and place the frames too. This clean scene (0.3 px / 0.1 px noise, no
// outliers) is easy; on the rendered loop the bend is a much flatter mode (docs/stages/slam.md).
TEST(GlobalRefinement, BentStripIsStraightened) {
  const double f = 1000, cx = 639.5, cy = 359.5, B = 0.3, h = 6.0;
  const RectifiedStereo cam{.f_px = f, .cx_px = cx, .cy_px = cy, .baseline_m = B, .width = 1280, .height = 720};
  const ScalePyramid pyr(1, 1.2);
  const int n_frames = 81, kf_every = 4;
  const double step_m = 0.5;
  // Truth: camera looking down (z down), moving along -y of the camera (image up) = +x of the world.
  Eigen::Matrix3d R_world_cam;
  R_world_cam << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  std::vector<Eigen::Isometry3d> T_world_cam(n_frames);
  for (int i = 0; i < n_frames; ++i) {
    T_world_cam[i].setIdentity();
    T_world_cam[i].linear() = R_world_cam;
    T_world_cam[i].translation() = Eigen::Vector3d(i * step_m, 0, h);
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-3, n_frames * step_m + 3), uy(-3.5, 3.5);
  std::normal_distribution<double> px_noise(0, 0.3), d_noise(0, 0.1);
  std::vector<Eigen::Vector3d> ground(6000);
  for (auto& p : ground) p = Eigen::Vector3d(ux(rng), uy(rng), 0);

  // Bent initial guess: pitch error growing to 3 deg at the far end, positions integrated along it.
  std::vector<Eigen::Isometry3d> T_guess(n_frames);
  Eigen::Vector3d pos(0, 0, h);
  for (int i = 0; i < n_frames; ++i) {
    const double pitch = 3.0 * M_PI / 180 * std::sin(M_PI * i / (n_frames - 1));
    const Eigen::Matrix3d tilt = Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()).toRotationMatrix();
    if (i > 0) pos += tilt * Eigen::Vector3d(step_m, 0, 0);
    T_guess[i].setIdentity();
    T_guess[i].linear() = tilt * R_world_cam;
    T_guess[i].translation() = pos;
  }

  // Builds the bent map, refines it with the given disparity sigma; returns the RMS camera position
  // error (m) before and after.
  auto run = [&](double sigma_d) {
    std::mt19937 obs_rng(11);
    SlamMap map;
    std::vector<RefinedFrame> frames;
    std::vector<int> frame_index;  // frames[] -> frame
    std::vector<int> point_of(ground.size(), -1);
    for (int i = 0; i < n_frames; ++i) {
      const Eigen::Isometry3d T_cam_world = T_world_cam[i].inverse();
      const bool key = i % kf_every == 0;
      Keyframe kf;
      RefinedFrame fr;
      std::vector<int> seen;
      for (size_t g = 0; g < ground.size(); ++g) {
        const Eigen::Vector3d pc = T_cam_world * ground[g];
        const double u = f * pc.x() / pc.z() + cx, v = f * pc.y() / pc.z() + cy;
        if (u < 0 || v < 0 || u > 1279 || v > 719) continue;
        if (!key && point_of[g] < 0) continue;  // a frame only matches existing map points
        const double un = u + px_noise(obs_rng), vn = v + px_noise(obs_rng);
        const double ur = un - (f * B / pc.z() + d_noise(obs_rng));
        if (key) {
          kf.features.keypoints.emplace_back(static_cast<float>(un), static_cast<float>(vn), 31.f, -1.f, 0.f, 0);
          kf.features.u_right.push_back(static_cast<float>(ur));
          kf.features.depth_m.push_back(static_cast<float>(f * B / (un - ur)));
          seen.push_back(static_cast<int>(g));
        } else {
          fr.observations.push_back(
              {static_cast<float>(un), static_cast<float>(vn), static_cast<float>(ur), 0, point_of[g]});
        }
      }
      if (key) {
        kf.id = static_cast<int>(map.keyframes.size());
        kf.frame_index = i;
        kf.T_cam_world = T_guess[i].inverse();
        kf.points.assign(kf.features.size(), -1);
        kf.features.descriptors = cv::Mat::zeros(static_cast<int>(kf.features.size()), 32, CV_8U);
        map.keyframes.push_back(std::move(kf));
        const Keyframe& k = map.keyframes.back();
        for (size_t j = 0; j < seen.size(); ++j) {
          const int g = seen[j];
          if (point_of[g] < 0) {
            // New point from this keyframe's (noisy) stereo in its bent pose, as the front end makes it.
            const cv::Point2f kp = k.features.keypoints[j].pt;
            const double z = k.features.depth_m[j];
            const Eigen::Vector3d p_cam((kp.x - cx) * z / f, (kp.y - cy) * z / f, z);
            point_of[g] = map.AddPoint(k.T_cam_world.inverse() * p_cam, k.id, static_cast<int>(j));
          } else {
            map.AddObservation(point_of[g], k.id, static_cast<int>(j));
          }
        }
      } else {
        fr.T_cam_world = T_guess[i].inverse();
        frames.push_back(std::move(fr));
        frame_index.push_back(i);
      }
    }
    auto rms_error = [&](bool refined) {
      double s2 = 0;
      int n = 0;
      for (const Keyframe& k : map.keyframes) {
        s2 += (k.Center() - T_world_cam[k.frame_index].translation()).squaredNorm();
        ++n;
      }
      for (size_t j = 0; j < frames.size(); ++j) {
        if (refined && !frames[j].refined) continue;
        s2 += (frames[j].T_cam_world.inverse().translation() - T_world_cam[frame_index[j]].translation()).squaredNorm();
        ++n;
      }
      return std::sqrt(s2 / n);
    };
    const double before = rms_error(false);
    const BundleAdjustSummary s = GlobalBundleAdjustWithFrames(&map, &frames, cam, pyr, 20, {0}, sigma_d);
    EXPECT_EQ(s.keyframes, static_cast<int>(map.keyframes.size()) - 1);
    for (const RefinedFrame& fr : frames) EXPECT_TRUE(fr.refined);
    return std::make_pair(before, rms_error(true));
  };
  const auto [before, weighted] = run(0.1);
  const auto [before_plain, plain] = run(0.0);
  EXPECT_GT(before, 0.5);  // the bend: ~1 m of height at mid-strip
  EXPECT_LT(weighted, 0.1) << "before " << before << " m";
  EXPECT_LT(plain, 0.1) << "before " << before << " m";
}

}  // namespace
}  // namespace rs
