#pragma once
// A synthetic rectified road pair with exact planar + pothole disparity, and the type every
// stereo pair with left-view truth is held in (simulated or loaded), for tests and benchmarks.

#include <string>

#include <opencv2/core/mat.hpp>

namespace rs {

/// A rectified grey pair with left-view truth.
struct StereoPairWithTruth {
  std::string name;
  cv::Mat left, right;                          ///< CV_8UC1
  cv::Mat gt;                                   ///< CV_32F disparity of the left view, 0 = unknown
  cv::Mat nonocc;                               ///< CV_8U non-occluded truth pixels
  cv::Mat road;                                 ///< CV_8U evaluation mask (synthetic: undamaged road); may be empty
  cv::Mat pothole;                              ///< CV_8U pothole pixels (simulated surveys); may be empty
  int min_disparity = 0, num_disparities = 64;  ///< search range matching the scene
  double focal_px = 0;  ///< rectified focal length where known (DisparityParams::camera_focal_px), else 0
};

/// Synthetic road: a textured plane with roll, seen with disparity d = c0 + cu u + cv v,
/// plus a bowl-shaped pothole (smaller disparity). Exact truth everywhere.
struct SyntheticRoadOptions {
  int width = 1280, height = 720;
  /// Road plane disparity, px: a drone camera pitched forward sees ~47 px at the top right,
  /// ~103 px at the bottom left (plain SGM then needs [0, 112)).
  double c0 = 60, cu = -0.01, cv = 0.06;
  double pothole_u = 700, pothole_v = 520, pothole_radius_px = 90,
         pothole_depth_px = 5;  ///< depth: disparity drop at centre
  double noise_sigma = 2.0;     ///< grey-level sensor noise added to both views
  unsigned seed = 7;
};
StereoPairWithTruth MakeSyntheticRoadPair(const SyntheticRoadOptions& options);

}  // namespace rs
