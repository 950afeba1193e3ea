#pragma once
// The disparity stage's per-frame files, written by the stage and read by the damage stage, the
// evaluators and the CLI: KITTI 16-bit disparity PNGs (value = round(d * 256), 0 = invalid), the
// validity mask, 32-bit float TIFFs (transformed disparity), a point cloud and a colour preview.

#include <filesystem>
#include <string>

#include <opencv2/core/mat.hpp>

namespace rs {

struct RectifiedStereo;

/// File names inside one frame folder of the disparity stage's output.
namespace disparity_files {
inline constexpr const char* kDisparity = "disparity.png";       ///< KITTI 16-bit, the stage's disparity
inline constexpr const char* kSharp = "disparity_sharp.png";     ///< KITTI 16-bit, small refinement window alone
inline constexpr const char* kValid = "valid.png";               ///< CV_8U 255 = valid
inline constexpr const char* kTransformed = "transformed.tiff";  ///< CV_32F transformed disparity (eq. 5)
inline constexpr const char* kRoadModel = "road_model.json";     ///< the frame's road disparity model
inline constexpr const char* kPreview = "preview.png";           ///< colour preview with a scale
inline constexpr const char* kPointCloud = "cloud.ply";          ///< binary PLY of the valid pixels
}  // namespace disparity_files

/// CV_16U image in the KITTI convention: round(d * 256) clamped to [1, 65535] on valid pixels
/// with d > 0, 0 elsewhere (KITTI cannot store d <= 0).
cv::Mat ToKittiDisparity16(const cv::Mat& disparity, const cv::Mat& valid);

/// Inverse of ToKittiDisparity16: CV_32F disparity (0 invalid) and the validity mask.
void FromKittiDisparity16(const cv::Mat& png16, cv::Mat* disparity, cv::Mat* valid);

/// Writes ToKittiDisparity16 as PNG; throws std::runtime_error when writing fails.
void WriteKittiDisparityPng(const std::string& path, const cv::Mat& disparity, const cv::Mat& valid);

/// Reads a KITTI 16-bit disparity PNG: CV_32F disparity (value / 256, 0 = invalid) and, when
/// `valid` is given, the CV_8U mask of valid pixels. Throws InputError naming the file when it is
/// missing, cannot be decoded, or is not a single-channel 16-bit image.
cv::Mat ReadKittiDisparityPng(const std::filesystem::path& path, cv::Mat* valid = nullptr);

/// Writes an image through the checked writer (PNG masks, 32-bit float TIFFs); throws WriteError
/// naming the file when the encoder or the write fails.
void WriteImageChecked(const std::string& path, const cv::Mat& image);

/// Binary little-endian PLY of the valid pixels' 3-D points in the left camera frame (x right,
/// y down, z forward, metres) with their grey value; throws std::runtime_error when writing fails.
void WriteDisparityPointCloud(const std::string& path, const cv::Mat& disparity, const cv::Mat& valid,
                              const cv::Mat& gray, const RectifiedStereo& camera);

/// BGR preview: disparity in [d_min, d_max] through the turbo colour map, invalid pixels black,
/// with a colour bar on the right labelled in px.
cv::Mat ColorizeDisparity(const cv::Mat& disparity, const cv::Mat& valid, double d_min, double d_max);

}  // namespace rs
