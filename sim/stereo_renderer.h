#pragma once
// Renders the left and right images of the stereo rig by casting one ray per
// pixel into the RoadScene, plus per-pixel truth (depth, damage label) for the
// left camera. Rows run in parallel (oneTBB).

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "formats/stereo_calibration.h"
#include "sim/road_scene.h"
#include "sim/simulation_options.h"

namespace rs::sim {

/// One rendered camera image and (optionally) its truth.
struct RenderedView {
  cv::Mat gray;     ///< CV_8UC1 image
  cv::Mat depth_m;  ///< CV_32FC1 depth along the optical axis (camera z), 0 = nothing hit
  cv::Mat label;    ///< CV_16UC1 damage instance id, 0 = none
};

/// The calibration the simulator renders with (rectified or raw) from the options.
StereoCalibration MakeCalibration(const SimulationOptions& o);

class StereoRenderer {
 public:
  StereoRenderer(const RoadScene& scene, const SimulationOptions& o, const StereoCalibration& calib);

  /// Renders camera `cam` (0 left, 1 right). T_world_left: left camera poses over
  /// the exposure (one = no motion blur; truth uses the middle one). frame_key
  /// seeds the sensor noise. Truth images are filled when with_truth.
  void Render(const std::vector<Eigen::Isometry3d>& T_world_left, int cam, uint64_t frame_key, bool with_truth,
              RenderedView* out) const;

 private:
  struct Camera {
    int width = 0, height = 0;
    std::vector<Eigen::Vector3f> rays;  // unit ray per pixel, camera frame
    // Per pixel (dx/du, dy/du, dx/dv, dy/dv) / |(x, y, 1)|, (x, y) the normalised image coordinates: the
    // ray's change per pixel step (camera frame, along x and y), for the texture filter's footprint.
    std::vector<Eigen::Vector4f> ray_diff;
    std::vector<float> vignette;  // brightness factor per pixel
    double gain = 1;
    Eigen::Isometry3d T_left_cam = Eigen::Isometry3d::Identity();
  };
  Camera MakeCamera(const CameraIntrinsics& K, bool distorted, double gain) const;

  const RoadScene& scene_;
  SimulationOptions o_;
  Camera cams_[2];
};

}  // namespace rs::sim
