#include "formats/disparity/disparity_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "formats/checked_file.h"
#include "formats/image_file.h"
#include "formats/input_error.h"
#include "formats/rectified_stereo.h"

namespace rs {

cv::Mat ToKittiDisparity16(const cv::Mat& d, const cv::Mat& valid) {
  cv::Mat out = cv::Mat::zeros(d.size(), CV_16U);
  for (int v = 0; v < d.rows; ++v)
    for (int u = 0; u < d.cols; ++u) {
      const float x = d.at<float>(v, u);
      if (!valid.at<uint8_t>(v, u) || !(x > 0)) continue;
      out.at<uint16_t>(v, u) = static_cast<uint16_t>(std::clamp(std::lround(x * 256.0), 1L, 65535L));
    }
  return out;
}

void FromKittiDisparity16(const cv::Mat& png16, cv::Mat* d, cv::Mat* valid) {
  if (png16.type() != CV_16U) throw std::invalid_argument("kitti disparity: expected a 16-bit single-channel image");
  png16.convertTo(*d, CV_32F, 1.0 / 256.0);
  *valid = png16 > 0;
}

void WriteKittiDisparityPng(const std::string& path, const cv::Mat& d, const cv::Mat& valid) {
  WriteImageFile(path, ToKittiDisparity16(d, valid));
}

cv::Mat ReadKittiDisparityPng(const std::filesystem::path& path, cv::Mat* valid) {
  const InputLocation where = InputLocation::File(path.string());
  if (!std::filesystem::is_regular_file(path)) throw InputError(where, "no such file");
  const cv::Mat png = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (png.empty()) throw InputError(where, "cannot decode image");
  if (png.type() != CV_16UC1) throw InputError(where, "expected a KITTI 16-bit single-channel disparity PNG (d * 256)");
  cv::Mat d, v;
  FromKittiDisparity16(png, &d, &v);
  if (valid) *valid = v;
  return d;
}

void WriteImageChecked(const std::string& path, const cv::Mat& image) { WriteImageFile(path, image); }

void WriteDisparityPointCloud(const std::string& path, const cv::Mat& disparity, const cv::Mat& valid,
                              const cv::Mat& gray, const RectifiedStereo& camera) {
  const double f_px = camera.f_px, cx_px = camera.cx_px, cy_px = camera.cy_px, baseline_m = camera.baseline_m;
  struct Point {
    float x, y, z;
    uint8_t g;
  } __attribute__((packed));
  std::vector<Point> points;
  for (int v = 0; v < disparity.rows; ++v) {
    for (int u = 0; u < disparity.cols; ++u) {
      const float d = disparity.at<float>(v, u);
      if (!valid.at<uint8_t>(v, u) || d <= 0) continue;
      const double z = f_px * baseline_m / d;
      points.push_back({static_cast<float>((u - cx_px) * z / f_px), static_cast<float>((v - cy_px) * z / f_px),
                        static_cast<float>(z), gray.at<uint8_t>(v, u)});
    }
  }
  WriteStreamChecked(path, [&](std::ostream& out) {
    out << "ply\nformat binary_little_endian 1.0\ncomment roadsurvey disparity point cloud, left camera frame, metres\n"
        << "element vertex " << points.size() << "\nproperty float x\nproperty float y\nproperty float z\n"
        << "property uchar intensity\nend_header\n";
    out.write(reinterpret_cast<const char*>(points.data()),
              static_cast<std::streamsize>(points.size() * sizeof(Point)));
  });
}

cv::Mat ColorizeDisparity(const cv::Mat& d, const cv::Mat& valid, double d_min, double d_max) {
  const double span = std::max(1e-6, d_max - d_min);
  cv::Mat grey(d.size(), CV_8U);
  for (int v = 0; v < d.rows; ++v)
    for (int u = 0; u < d.cols; ++u)
      grey.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(255.0 * (d.at<float>(v, u) - d_min) / span);
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar::all(0), valid == 0);
  // Colour bar: 24 px strip plus labels, top = d_max.
  const int bar_w = 24, label_w = 70, H = d.rows;
  cv::Mat canvas(H, d.cols + bar_w + label_w, CV_8UC3, cv::Scalar::all(255));
  colour.copyTo(canvas(cv::Rect(0, 0, d.cols, H)));
  cv::Mat ramp(H, 1, CV_8U);
  for (int v = 0; v < H; ++v)
    ramp.at<uint8_t>(v, 0) = cv::saturate_cast<uint8_t>(255.0 * (H - 1 - v) / std::max(1, H - 1));
  cv::Mat ramp_c;
  cv::applyColorMap(ramp, ramp_c, cv::COLORMAP_TURBO);
  cv::resize(ramp_c, ramp_c, cv::Size(bar_w, H), 0, 0, cv::INTER_NEAREST);
  ramp_c.copyTo(canvas(cv::Rect(d.cols, 0, bar_w, H)));
  const double font = std::max(0.35, H / 1200.0);
  for (int i = 0; i <= 4; ++i) {
    const double val = d_max - span * i / 4.0;
    const int y = std::clamp(static_cast<int>(std::lround((H - 1) * i / 4.0)), 12, H - 4);
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.1f px", val);
    cv::putText(canvas, buf, cv::Point(d.cols + bar_w + 3, y), cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar::all(0), 1,
                cv::LINE_AA);
  }
  return canvas;
}

}  // namespace rs
