#pragma once
// A COLMAP sparse model (cameras, images, points3D) as COLMAP 3.8 reads and writes it, in its
// text (cameras.txt, images.txt, points3D.txt) and binary (cameras.bin, images.bin, points3D.bin)
// forms. Poses are COLMAP's: world -> camera, quaternion w first. Pixel coordinates are COLMAP's:
// the centre of the top-left pixel is (0.5, 0.5). https://colmap.github.io/format.html

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace rs {

/// A camera model COLMAP knows: its name, numeric id in the binary files and parameter count.
struct ColmapCameraModel {
  const char* name;
  int id;
  int num_params;
};
/// The model named `name` ("PINHOLE"), or nullopt.
std::optional<ColmapCameraModel> FindColmapCameraModel(const std::string& name);
/// The model with binary id `id`, or nullopt.
std::optional<ColmapCameraModel> FindColmapCameraModel(int id);

struct ColmapCamera {
  uint32_t id = 0;
  std::string model = "PINHOLE";
  uint64_t width = 0, height = 0;  ///< px
  std::vector<double> params;      ///< PINHOLE: fx fy cx cy
};

/// COLMAP's "no 3D point" in an image's 2D point list.
inline constexpr uint64_t kColmapNoPoint3D = UINT64_MAX;

struct ColmapPoint2D {
  double x = 0, y = 0;                   ///< px, COLMAP convention
  uint64_t point3d_id = kColmapNoPoint3D;
};

struct ColmapImage {
  uint32_t id = 0;
  Eigen::Quaterniond q_cam_world = Eigen::Quaterniond::Identity();  ///< world -> camera
  Eigen::Vector3d t_cam_world = Eigen::Vector3d::Zero();
  uint32_t camera_id = 0;
  std::string name;  ///< relative image path, e.g. "left/000012.png"
  std::vector<ColmapPoint2D> points2d;

  Eigen::Isometry3d T_cam_world() const;
  void SetPose(const Eigen::Isometry3d& T_cam_world);
};

struct ColmapTrackElement {
  uint32_t image_id = 0;
  uint32_t point2d_idx = 0;  ///< index into that image's points2d
  bool operator==(const ColmapTrackElement& o) const { return image_id == o.image_id && point2d_idx == o.point2d_idx; }
};

struct ColmapPoint3D {
  uint64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<uint8_t, 3> rgb = {128, 128, 128};
  double error = -1;  ///< mean reprojection error COLMAP stores, px (-1: not computed)
  std::vector<ColmapTrackElement> track;
};

struct ColmapModel {
  std::vector<ColmapCamera> cameras;
  std::vector<ColmapImage> images;
  std::vector<ColmapPoint3D> points;

  const ColmapCamera* FindCamera(uint32_t id) const;
  const ColmapImage* FindImage(uint32_t id) const;
};

}  // namespace rs
