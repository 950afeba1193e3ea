#pragma once
// Disparity export: KITTI 16-bit PNG (value = round(d * 256), 0 = invalid) and a colour-mapped
// preview with a labelled colour scale.

#include <string>

#include <opencv2/core/mat.hpp>

namespace rs {

/// CV_16U image in the KITTI convention: round(d * 256) clamped to [1, 65535] on valid pixels
/// with d > 0, 0 elsewhere (KITTI cannot store d <= 0).
cv::Mat ToKittiDisparity16(const cv::Mat& disparity, const cv::Mat& valid);

/// Inverse of ToKittiDisparity16: CV_32F disparity (0 invalid) and the validity mask.
void FromKittiDisparity16(const cv::Mat& png16, cv::Mat* disparity, cv::Mat* valid);

/// Writes ToKittiDisparity16 as PNG; throws std::runtime_error when writing fails.
void WriteKittiDisparityPng(const std::string& path, const cv::Mat& disparity, const cv::Mat& valid);

/// BGR preview: disparity in [d_min, d_max] through the turbo colour map, invalid pixels black,
/// with a colour bar on the right labelled in px.
cv::Mat ColorizeDisparity(const cv::Mat& disparity, const cv::Mat& valid, double d_min, double d_max);

}  // namespace rs
