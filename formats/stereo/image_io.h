#pragma once
// Loading stereo images of any common bit depth and channel count into the 8-bit
// forms the pipeline works on. Bit-depth rules: docs/formats/stereo-sources.md.

#include <filesystem>
#include <opencv2/core/mat.hpp>

namespace rs {

/// Decodes an image file exactly as stored (8/16-bit, 1/3/4 channels; PNG, JPEG, TIFF).
/// Throws InputError naming the file when it is missing, empty, truncated (PNG without
/// IEND, JPEG without end-of-image marker) or does not decode, or has a depth other than
/// 8/16-bit unsigned.
cv::Mat LoadImageRaw(const std::filesystem::path& path);

/// Converts any image LoadImageRaw returns to 8-bit single channel. Colour -> grey with
/// OpenCV's BT.601 weights (Y = 0.299 R + 0.587 G + 0.114 B). 16-bit -> 8-bit by the fixed
/// linear rule v8 = round(v16 * 255 / (2^significant_bits - 1)), saturated; the rule does
/// not depend on the image content so left and right (and all frames) scale alike.
/// significant_bits: 16 for full-range data, 12 or 10 for sensor data stored in 16 bits.
cv::Mat ToGray8(const cv::Mat& image, int significant_bits = 16);
/// Same as ToGray8 but keeps colour: 8-bit BGR (grey images are replicated).
cv::Mat ToColor8(const cv::Mat& image, int significant_bits = 16);

/// LoadImageRaw then ToGray8.
cv::Mat LoadGray8(const std::filesystem::path& path, int significant_bits = 16);
/// LoadImageRaw then ToColor8.
cv::Mat LoadColor8(const std::filesystem::path& path, int significant_bits = 16);

}  // namespace rs
