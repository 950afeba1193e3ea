#include "formats/colmap/colmap_model.h"

#include <algorithm>

namespace rs {
namespace {

// COLMAP 3.8, src/base/camera_models.h: the numeric ids are those of the binary files.
constexpr ColmapCameraModel kModels[] = {
    {"SIMPLE_PINHOLE", 0, 3}, {"PINHOLE", 1, 4},        {"SIMPLE_RADIAL", 2, 4},         {"RADIAL", 3, 5},
    {"OPENCV", 4, 8},         {"OPENCV_FISHEYE", 5, 8}, {"FULL_OPENCV", 6, 12},          {"FOV", 7, 5},
    {"SIMPLE_RADIAL_FISHEYE", 8, 4}, {"RADIAL_FISHEYE", 9, 5}, {"THIN_PRISM_FISHEYE", 10, 12},
};

}  // namespace

std::optional<ColmapCameraModel> FindColmapCameraModel(const std::string& name) {
  for (const auto& m : kModels)
    if (name == m.name) return m;
  return std::nullopt;
}

std::optional<ColmapCameraModel> FindColmapCameraModel(int id) {
  for (const auto& m : kModels)
    if (id == m.id) return m;
  return std::nullopt;
}

Eigen::Isometry3d ColmapImage::T_cam_world() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q_cam_world.normalized().toRotationMatrix();
  T.translation() = t_cam_world;
  return T;
}

void ColmapImage::SetPose(const Eigen::Isometry3d& T) {
  q_cam_world = Eigen::Quaterniond(T.linear()).normalized();
  if (q_cam_world.w() < 0) q_cam_world.coeffs() *= -1;  // one sign for the same rotation
  t_cam_world = T.translation();
}

const ColmapCamera* ColmapModel::FindCamera(uint32_t id) const {
  const auto it = std::find_if(cameras.begin(), cameras.end(), [&](const auto& c) { return c.id == id; });
  return it == cameras.end() ? nullptr : &*it;
}

const ColmapImage* ColmapModel::FindImage(uint32_t id) const {
  const auto it = std::find_if(images.begin(), images.end(), [&](const auto& c) { return c.id == id; });
  return it == images.end() ? nullptr : &*it;
}

}  // namespace rs
