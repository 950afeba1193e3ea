#pragma once
// Readers and writers of COLMAP sparse models (text and binary, COLMAP 3.8 layouts) and of the
// rig configuration `colmap rig_bundle_adjuster` reads. Every reader throws InputError naming the
// file and the line (text) or byte offset (binary) of bad content; counts in binary files are
// checked against the bytes left before anything is allocated, so no input can make a reader
// allocate more than its own size or loop without end.

#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "formats/colmap/colmap_model.h"

namespace rs {

enum class ColmapFormat { kText, kBinary };

// Text files (cameras.txt, images.txt, points3D.txt).
std::vector<ColmapCamera> ReadColmapCamerasText(std::istream& in, const std::string& path_for_errors);
std::vector<ColmapImage> ReadColmapImagesText(std::istream& in, const std::string& path_for_errors);
std::vector<ColmapPoint3D> ReadColmapPointsText(std::istream& in, const std::string& path_for_errors);
void WriteColmapCamerasText(std::ostream& out, const std::vector<ColmapCamera>& cameras);
void WriteColmapImagesText(std::ostream& out, const std::vector<ColmapImage>& images);
void WriteColmapPointsText(std::ostream& out, const std::vector<ColmapPoint3D>& points);

// Binary files (little-endian, as COLMAP writes them on x86 and ARM).
std::vector<ColmapCamera> ReadColmapCamerasBinary(std::string_view bytes, const std::string& path_for_errors);
std::vector<ColmapImage> ReadColmapImagesBinary(std::string_view bytes, const std::string& path_for_errors);
std::vector<ColmapPoint3D> ReadColmapPointsBinary(std::string_view bytes, const std::string& path_for_errors);
std::string ColmapCamerasBinary(const std::vector<ColmapCamera>& cameras);
std::string ColmapImagesBinary(const std::vector<ColmapImage>& images);
std::string ColmapPointsBinary(const std::vector<ColmapPoint3D>& points);

/// Reads a model folder: the binary files when cameras.bin is there (as COLMAP does), else the
/// text files. Also checks that the three agree (every referenced camera, image, 2D point and 3D
/// point exists; a 2D point and the track naming it point at each other).
ColmapModel ReadColmapModel(const std::filesystem::path& dir);
/// Writes the three files of `format` into `dir` (created) through the checked writer.
void WriteColmapModel(const std::filesystem::path& dir, const ColmapModel& model, ColmapFormat format);

/// One camera of a rig: its images are those whose name starts with image_prefix, and its pose
/// relative to the rig (the reference camera) is camera-from-rig (x_cam = R x_rig + t).
struct ColmapRigCamera {
  uint32_t camera_id = 0;
  std::string image_prefix;  ///< e.g. "left/"
  Eigen::Isometry3d T_cam_rig = Eigen::Isometry3d::Identity();
};
struct ColmapRig {
  uint32_t ref_camera_id = 0;
  std::vector<ColmapRigCamera> cameras;
};
/// The rig configuration JSON of `colmap rig_bundle_adjuster --rig_config_path` (a list of rigs;
/// rel_qvec is w first, as everywhere in COLMAP).
std::string ColmapRigConfigJson(const std::vector<ColmapRig>& rigs);
std::vector<ColmapRig> ReadColmapRigConfig(std::istream& in, const std::string& path_for_errors);

}  // namespace rs
