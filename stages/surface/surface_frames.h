#pragma once
// The frames the surface is fused from: their files, and each frame's camera-to-CRS transform
// (pose, georeference similarity and the CRS linearised at the frame).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "formats/geo/georeference_file.h"
#include "formats/rectified_stereo.h"
#include "stages/surface/frame_cells.h"

namespace rs {

struct SurfaceFrame {
  int64_t id = 0;
  std::filesystem::path disparity, left, road_mask, road_model;  ///< the damage stage's road.png; road_model may be absent
  std::filesystem::path disparity_sharp, damage_labels;          ///< empty / absent: the smooth disparity everywhere
  Eigen::Matrix<double, 3, 4> crs_from_camera = Eigen::Matrix<double, 3, 4>::Zero();
};

/// Camera-to-CRS affine for a camera at `T_world_camera` (SLAM world): the SLAM-to-ENU similarity,
/// then the CRS linearised by central differences at the camera (exact to well below a millimetre
/// over a frame's footprint: the map's scale and convergence change by parts per million per km).
Eigen::Matrix<double, 3, 4> CrsFromCamera(const Eigen::Isometry3d& T_world_camera, const GeoreferenceFile& geo,
                                          const OutputCrs& crs);

/// How a frame's pixels are chosen and weighted (from the stage's options).
struct FrameLoadOptions {
  double disparity_sigma_px = 0;  ///< 0: the road fit's residual (road_model.json)
  double min_disparity_sigma_px = 0.1;
  double max_range_m = 0;
  int damage_margin_px = 10;  ///< the sharp disparity within this distance of a detected damage
  bool colour = true;  ///< decode the left image (off for the footprint pass)
};

/// Loads one frame's disparity (the disparity stage's sharp image, which keeps a pothole's wall in
/// place, around the damage stage's detections; its smooth image elsewhere, less noisy), road mask (the damage stage's: road and damage, no obstacles, no
/// islands of mismatches) and left image. Throws InputError naming the file on an unreadable one.
FrameView LoadFrameView(const SurfaceFrame& f, const RectifiedStereo& camera, const FrameLoadOptions& o);

}  // namespace rs
