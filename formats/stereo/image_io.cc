#include "formats/stereo/image_io.h"

#include <algorithm>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "formats/input_error.h"

namespace rs {
namespace {

constexpr size_t kMaxImageBytes = size_t{1} << 31;  // 2 GiB: beyond any camera frame

bool EndsWithin(const std::vector<uchar>& b, const std::vector<uchar>& marker, size_t window) {
  if (b.size() < marker.size()) return false;
  const size_t from = b.size() > window ? b.size() - window : 0;
  return std::search(b.begin() + static_cast<std::ptrdiff_t>(from), b.end(), marker.begin(), marker.end()) != b.end();
}

}  // namespace

cv::Mat LoadImageRaw(const std::filesystem::path& path) {
  const std::string p = path.string();
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(InputLocation::File(p), "cannot open image");
  const std::streamoff size = in.tellg();
  if (size <= 0) throw InputError(InputLocation::File(p), "empty image file");
  if (static_cast<size_t>(size) > kMaxImageBytes)
    throw InputError(InputLocation::File(p), "image file larger than 2 GiB");
  std::vector<uchar> bytes(static_cast<size_t>(size));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) throw InputError(InputLocation::File(p), "read error");

  // Decoders may return a partially filled image for a truncated file (libjpeg does, with
  // only a warning); check the end markers so a cut-off transfer is an error, not grey rows.
  static const std::vector<uchar> kPngMagic = {0x89, 'P', 'N', 'G'}, kPngEnd = {'I', 'E', 'N', 'D'};
  static const std::vector<uchar> kJpegEnd = {0xFF, 0xD9};
  if (bytes.size() >= 4 && std::equal(kPngMagic.begin(), kPngMagic.end(), bytes.begin()) &&
      !EndsWithin(bytes, kPngEnd, 64))
    throw InputError(InputLocation::Byte(p, static_cast<int64_t>(bytes.size())), "truncated PNG (no IEND chunk)");
  if (bytes.size() >= 2 && bytes[0] == 0xFF && bytes[1] == 0xD8 && !EndsWithin(bytes, kJpegEnd, 64))
    throw InputError(InputLocation::Byte(p, static_cast<int64_t>(bytes.size())),
                     "truncated JPEG (no end-of-image marker)");
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(InputLocation::File(p), "image does not decode: " + e.err);
  }
  if (image.empty()) throw InputError(InputLocation::File(p), "image does not decode (corrupt or unsupported format)");
  if (image.depth() != CV_8U && image.depth() != CV_16U)
    throw InputError(InputLocation::File(p), "unsupported pixel depth (only 8- and 16-bit unsigned)");
  if (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)
    throw InputError(InputLocation::File(p), "unsupported channel count " + std::to_string(image.channels()));
  return image;
}

namespace {

cv::Mat To8Bit(const cv::Mat& image, int significant_bits) {
  if (image.depth() == CV_8U) return image;
  if (significant_bits < 8 || significant_bits > 16)
    throw std::invalid_argument("significant_bits must be in [8, 16]");  // caller bug, not input
  cv::Mat out;
  image.convertTo(out, CV_8U, 255.0 / ((1 << significant_bits) - 1));  // rounds and saturates
  return out;
}

}  // namespace

cv::Mat ToGray8(const cv::Mat& image, int significant_bits) {
  cv::Mat m = To8Bit(image, significant_bits), out;
  if (m.channels() == 1) return m;
  cv::cvtColor(m, out, m.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
  return out;
}

cv::Mat ToColor8(const cv::Mat& image, int significant_bits) {
  cv::Mat m = To8Bit(image, significant_bits), out;
  if (m.channels() == 3) return m;
  cv::cvtColor(m, out, m.channels() == 1 ? cv::COLOR_GRAY2BGR : cv::COLOR_BGRA2BGR);
  return out;
}

cv::Mat LoadGray8(const std::filesystem::path& path, int significant_bits) {
  return ToGray8(LoadImageRaw(path), significant_bits);
}

cv::Mat LoadColor8(const std::filesystem::path& path, int significant_bits) {
  return ToColor8(LoadImageRaw(path), significant_bits);
}

}  // namespace rs
