#pragma once
// Writing images through the checked writer: encoded to memory by the file name's extension
// (PNG, TIFF, JPEG), then written with WriteFileChecked. cv::imwrite is not used: with TIFF it
// reports success after libtiff's write errors, leaving a truncated file.

#include <opencv2/core/mat.hpp>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <string_view>
#include <vector>

#include "formats/checked_file.h"

namespace rs {

/// Encodes `image` by the extension of `path` and writes it; throws WriteError naming the file
/// when the encoder rejects the image or the write fails.
inline void WriteImageFile(const std::filesystem::path& path, const cv::Mat& image) {
  std::vector<uchar> bytes;
  bool encoded = false;
  try {
    encoded = cv::imencode(path.extension().string(), image, bytes);
  } catch (const cv::Exception& e) {
    throw WriteError(path, std::string("cannot encode image: ") + e.what());
  }
  if (!encoded) throw WriteError(path, "cannot encode image");
  WriteFileChecked(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace rs
