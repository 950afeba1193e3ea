#pragma once
// A synthetic stereo frame of a road with known truth, for tests and the per-frame
// benchmark: disparity map (and optionally a textured left image with cracks) of a
// camera above a plane with spherical-cap potholes and an optional raised slab.

#include "formats/rectified_stereo.h"

#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// A further pothole, placed on the road plane relative to the scene's first one.
struct SyntheticPothole {
  double across_m = 0;  ///< along the camera x axis (right)
  double along_m = 0;   ///< along the road, away from the camera
  double radius_m = 0.2, depth_m = 0.04;
};

/// Camera `height_m` above a plane, pitched `pitch_deg` below the horizon, one spherical-cap
/// pothole (depth, radius) at camera depth `pothole_z_m` on the optical axis' column (plus
/// `more_potholes`), optionally a raised slab (obstacle) of height `box_height_m` to the
/// right; disparity noise `sigma_d_px` (seeded).
struct SyntheticRoadScene {
  int width = 1280, height = 720;
  RectifiedStereo geometry{1000.0, 640.0, 360.0, 0.20};
  double height_m = 1.5, pitch_deg = 45.0;
  double pothole_depth_m = 0.06, pothole_radius_m = 0.25, pothole_z_m = 2.2;
  std::vector<SyntheticPothole> more_potholes;
  double box_height_m = 0;  ///< 0 = no obstacle
  double sigma_d_px = 0.05;
  double invalid_fraction = 0;  ///< share of 8×8 blocks without disparity (matching failures)
  int cracks = 0;               ///< RenderImage: this many dark cracks, 2–4 px wide, 150–450 px long
  unsigned seed = 3;
  /// Disparity map (CV_32F; 0 = no disparity) of the scene.
  cv::Mat Render() const;
  /// 8-bit grey left image: asphalt texture, darker pothole floors, a lane marking, `cracks`.
  cv::Mat RenderImage() const;
  /// Truth of the first pothole: area π a², depth h, volume π h² (3R − h) / 3.
  double TrueAreaM2() const;
  double TrueVolumeM3() const;
};

/// The benchmark frame: width × height (geometry scaled with the width), five potholes of
/// 0.24–0.8 m across and 25–60 mm deep, a 0.4 m slab, six cracks, σ_d 0.15 px and 2 % of
/// 8×8 blocks without disparity.
SyntheticRoadScene BenchmarkRoadScene(int width, int height);

}  // namespace rs
