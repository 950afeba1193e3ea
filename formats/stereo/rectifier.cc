#include "formats/stereo/rectifier.h"

#include <xxhash.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "formats/stereo/calibration_check.h"

namespace rs {
namespace {

cv::Mat K(const CameraIntrinsics& c) { return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1); }
cv::Mat D(const CameraIntrinsics& c) { return cv::Mat(1, 5, CV_64F, const_cast<double*>(c.dist.data())).clone(); }

// The values that determine the maps, in a fixed order: the cache key.
std::vector<double> Key(const StereoCalibration& c, double alpha) {
  std::vector<double> k;
  for (const CameraIntrinsics* cam : {&c.left, &c.right}) {
    k.insert(k.end(), {double(cam->width), double(cam->height), cam->fx, cam->fy, cam->cx, cam->cy});
    k.insert(k.end(), cam->dist.begin(), cam->dist.end());
  }
  k.insert(k.end(), c.R_right_left.begin(), c.R_right_left.end());
  k.insert(k.end(), c.t_right_left.begin(), c.t_right_left.end());
  k.push_back(c.rectified ? 1 : 0);
  k.push_back(alpha);
  return k;
}

constexpr char kMagic[8] = {'R', 'S', 'R', 'E', 'C', 'T', '0', '1'};
constexpr int64_t kMaxPixels = int64_t{1} << 28;

}  // namespace

StereoRectifier StereoRectifier::Create(const StereoCalibration& raw, double alpha) {
  const std::string where = raw.source_path.empty() ? "<calibration>" : raw.source_path;
  CheckStereoCalibration(raw, where);
  if (raw.left.width <= 0 || raw.left.height <= 0 || raw.left.width != raw.right.width ||
      raw.left.height != raw.right.height)
    throw InputError(InputLocation::File(where), "rectification needs equal, known image sizes for both cameras");
  StereoRectifier r;
  r.raw_ = raw;
  r.alpha_ = alpha;
  if (raw.rectified) {
    r.identity_ = true;
    r.rect_ = raw;
    return r;
  }
  if (std::abs(raw.t_right_left[1]) > std::abs(raw.t_right_left[0]))
    throw InputError(InputLocation::File(where), "vertical stereo rig (|t_y| > |t_x|) is not supported");
  const cv::Size size(raw.left.width, raw.left.height);
  cv::Mat R(3, 3, CV_64F, const_cast<double*>(raw.R_right_left.data()));
  cv::Mat t(3, 1, CV_64F, const_cast<double*>(raw.t_right_left.data()));
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(K(raw.left), D(raw.left), K(raw.right), D(raw.right), size, R, t, R1, R2, P1, P2, Q,
                    cv::CALIB_ZERO_DISPARITY, alpha, size);
  cv::initUndistortRectifyMap(K(raw.left), D(raw.left), R1, P1, size, CV_16SC2, r.map1_left_, r.map2_left_);
  cv::initUndistortRectifyMap(K(raw.right), D(raw.right), R2, P2, size, CV_16SC2, r.map1_right_, r.map2_right_);
  for (int i = 0; i < 9; ++i) {
    r.R_rectleft_left_[i] = R1.at<double>(i / 3, i % 3);
    r.R_rectright_right_[i] = R2.at<double>(i / 3, i % 3);
  }
  StereoCalibration& rc = r.rect_;
  rc.rectified = true;
  rc.source_path = raw.source_path;
  rc.left.width = rc.right.width = size.width;
  rc.left.height = rc.right.height = size.height;
  rc.left.fx = rc.right.fx = P1.at<double>(0, 0);
  rc.left.fy = rc.right.fy = P1.at<double>(1, 1);
  rc.left.cx = rc.right.cx = P1.at<double>(0, 2);
  rc.left.cy = rc.right.cy = P1.at<double>(1, 2);
  // P2[0,3] = Tx * f with Tx the x offset of the right camera in the rectified frame (negative).
  rc.t_right_left = {P2.at<double>(0, 3) / P2.at<double>(0, 0), 0, 0};
  CheckStereoCalibration(rc, where);
  return r;
}

void StereoRectifier::Rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat* left_rect,
                              cv::Mat* right_rect) const {
  const cv::Size size(raw_.left.width, raw_.left.height);
  if (left_raw.size() != size || right_raw.size() != size)
    throw InputError(
        InputLocation::File(raw_.source_path),
        "image size differs from the calibration's " + std::to_string(size.width) + "x" + std::to_string(size.height));
  if (identity_) {
    *left_rect = left_raw.clone();
    *right_rect = right_raw.clone();
    return;
  }
  cv::remap(left_raw, *left_rect, map1_left_, map2_left_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::remap(right_raw, *right_rect, map1_right_, map2_right_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
}

void StereoRectifier::Save(const std::filesystem::path& path) const {
  std::vector<char> buf(kMagic, kMagic + 8);
  auto put = [&](const void* p, size_t n) { buf.insert(buf.end(), (const char*)p, (const char*)p + n); };
  const std::vector<double> key = Key(raw_, alpha_);
  const int64_t nkey = static_cast<int64_t>(key.size());
  put(&nkey, 8);
  put(key.data(), key.size() * 8);
  const std::vector<double> rect = Key(rect_, alpha_);
  put(rect.data(), rect.size() * 8);
  put(R_rectleft_left_.data(), 72);
  put(R_rectright_right_.data(), 72);
  const int64_t has_maps = identity_ ? 0 : 1;
  put(&has_maps, 8);
  if (has_maps)
    for (const cv::Mat* m : {&map1_left_, &map2_left_, &map1_right_, &map2_right_})
      put(m->data, m->total() * m->elemSize());
  const uint64_t h = XXH64(buf.data(), buf.size(), 0);
  put(&h, 8);
  WriteFileChecked(path, std::string_view(buf.data(), buf.size()));
}

std::optional<StereoRectifier> StereoRectifier::Load(const std::filesystem::path& path, const StereoCalibration& raw,
                                                     double alpha) {
  const std::string p = path.string();
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(InputLocation::File(p), "cannot open rectification cache");
  const std::streamoff size = in.tellg();
  const std::vector<double> key = Key(raw, alpha);
  const int64_t w = raw.left.width, h = raw.left.height;
  if (w <= 0 || h <= 0 || w * h > kMaxPixels) throw InputError(InputLocation::File(p), "calibration has no image size");
  const size_t header = 8 + 8 + 2 * key.size() * 8 + 144 + 8;
  const size_t maps = static_cast<size_t>(w * h) * (4 + 2) * 2;
  if (size < static_cast<std::streamoff>(header + 8))
    throw InputError(InputLocation::Byte(p, size), "rectification cache truncated");
  std::vector<char> buf(static_cast<size_t>(size));
  in.seekg(0);
  if (!in.read(buf.data(), size)) throw InputError(InputLocation::File(p), "read error");
  if (std::memcmp(buf.data(), kMagic, 8) != 0) throw InputError(InputLocation::Byte(p, 0), "not a rectification cache");
  uint64_t stored_hash;
  std::memcpy(&stored_hash, buf.data() + buf.size() - 8, 8);
  if (XXH64(buf.data(), buf.size() - 8, 0) != stored_hash)
    throw InputError(InputLocation::File(p), "rectification cache checksum mismatch (corrupt file)");
  size_t off = 8;
  auto get = [&](void* dst, size_t n) {
    if (off + n > buf.size() - 8)
      throw InputError(InputLocation::Byte(p, static_cast<int64_t>(off)), "cache truncated");
    std::memcpy(dst, buf.data() + off, n);
    off += n;
  };
  int64_t nkey;
  get(&nkey, 8);
  if (nkey != static_cast<int64_t>(key.size())) return std::nullopt;
  std::vector<double> stored(key.size()), rect(key.size());
  get(stored.data(), stored.size() * 8);
  if (stored != key) return std::nullopt;  // made from another calibration: recompute
  get(rect.data(), rect.size() * 8);
  StereoRectifier r;
  r.raw_ = raw;
  r.alpha_ = alpha;
  get(r.R_rectleft_left_.data(), 72);
  get(r.R_rectright_right_.data(), 72);
  int64_t has_maps;
  get(&has_maps, 8);
  // Rebuild the rectified calibration from the stored key-ordered values.
  StereoCalibration& rc = r.rect_;
  size_t i = 0;
  for (CameraIntrinsics* cam : {&rc.left, &rc.right}) {
    cam->width = static_cast<int>(rect[i++]);
    cam->height = static_cast<int>(rect[i++]);
    cam->fx = rect[i++];
    cam->fy = rect[i++];
    cam->cx = rect[i++];
    cam->cy = rect[i++];
    for (double& d : cam->dist) d = rect[i++];
  }
  for (double& v : rc.R_right_left) v = rect[i++];
  for (double& v : rc.t_right_left) v = rect[i++];
  rc.rectified = rect[i] != 0;
  rc.source_path = raw.source_path;
  r.identity_ = has_maps == 0;
  if (has_maps) {
    if (buf.size() != header + maps + 8)
      throw InputError(InputLocation::File(p), "rectification cache has a wrong size");
    const int ih = static_cast<int>(h), iw = static_cast<int>(w);
    for (cv::Mat* m : {&r.map1_left_, &r.map2_left_, &r.map1_right_, &r.map2_right_}) {
      const bool xy = (m == &r.map1_left_ || m == &r.map1_right_);
      m->create(ih, iw, xy ? CV_16SC2 : CV_16UC1);
      get(m->data, m->total() * m->elemSize());
    }
  }
  CheckStereoCalibration(rc, p);
  return r;
}

StereoRectifier StereoRectifier::LoadOrCreate(const StereoCalibration& raw, const std::filesystem::path& cache_path,
                                              double alpha, bool* loaded_from_cache) {
  if (std::filesystem::exists(cache_path)) {
    if (auto r = Load(cache_path, raw, alpha)) {
      if (loaded_from_cache) *loaded_from_cache = true;
      return std::move(*r);
    }
  }
  StereoRectifier r = Create(raw, alpha);
  r.Save(cache_path);
  if (loaded_from_cache) *loaded_from_cache = false;
  return r;
}

}  // namespace rs
