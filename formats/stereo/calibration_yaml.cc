#include "formats/stereo/calibration_yaml.h"

#include <array>
#include <cstdio>
#include <fstream>
#include <ostream>
#include <opencv2/core.hpp>
#include <set>

#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "formats/stereo/calibration_check.h"
#include "formats/stereo/opencv_yaml.h"

namespace rs {

using stereo_internal::OpenYamlText;
using stereo_internal::RequireInt;
using stereo_internal::RequireNumbers;
using stereo_internal::SlurpStream;

namespace {

std::array<double, 9> KValues(const CameraIntrinsics& c) { return {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1}; }

void WriteMatrix(std::ostream& out, const char* key, int rows, int cols, const double* v) {
  out << key << ": !!opencv-matrix\n   rows: " << rows << "\n   cols: " << cols << "\n   dt: d\n   data: [ ";
  char buf[40];
  for (int i = 0; i < rows * cols; ++i) {
    std::snprintf(buf, sizeof buf, "%.17g", v[i]);
    out << buf << (i + 1 < rows * cols ? ", " : " ]\n");
  }
}

void ReadCamera(const cv::FileNode& root, const std::string& side, const std::string& path, CameraIntrinsics* c) {
  const std::vector<double> K = RequireNumbers(root, "K_" + side, path, 9);
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1)
    throw InputError(InputLocation::File(path),
                     "K_" + side + " must be [fx 0 cx; 0 fy cy; 0 0 1] (skew and bottom row are not supported)");
  c->fx = K[0];
  c->cx = K[2];
  c->fy = K[4];
  c->cy = K[5];
  const std::vector<double> D = RequireNumbers(root, "D_" + side, path, 5);
  std::copy(D.begin(), D.end(), c->dist.begin());
}

}  // namespace

void WriteCalibrationYaml(std::ostream& out, const StereoCalibration& calib) {
  const std::string where = calib.source_path.empty() ? "<calibration>" : calib.source_path;
  CheckStereoCalibration(calib, where);
  if (calib.left.width != calib.right.width || calib.left.height != calib.right.height)
    throw InputError(InputLocation::File(where), "left and right image sizes differ; calibration.yaml holds one size");
  if (calib.left.width <= 0 || calib.left.height <= 0)
    throw InputError(InputLocation::File(where), "image size unknown; calibration.yaml requires image_width/height");
  // Written by hand rather than through cv::FileStorage so the layout is stable and the
  // format string is quoted as documented; %.17g makes the round trip bit-exact.
  out << "%YAML:1.0\n---\n"
      << "format: \"" << kNativeCalibrationFormat << "\"\n"
      << "rectified: " << (calib.rectified ? 1 : 0) << "\n"
      << "image_width: " << calib.left.width << "\n"
      << "image_height: " << calib.left.height << "\n";
  WriteMatrix(out, "K_left", 3, 3, KValues(calib.left).data());
  WriteMatrix(out, "D_left", 1, 5, calib.left.dist.data());
  WriteMatrix(out, "K_right", 3, 3, KValues(calib.right).data());
  WriteMatrix(out, "D_right", 1, 5, calib.right.dist.data());
  WriteMatrix(out, "R_right_left", 3, 3, calib.R_right_left.data());
  WriteMatrix(out, "t_right_left", 3, 1, calib.t_right_left.data());
  if (!out) throw InputError(InputLocation::File(where), "write error");
}

void WriteCalibrationYaml(const std::filesystem::path& path, const StereoCalibration& calib) {
  WriteStreamChecked(path, [&](std::ostream& out) { WriteCalibrationYaml(out, calib); });
}

StereoCalibration ReadCalibrationYaml(std::istream& in, const std::string& path) {
  const std::string text = SlurpStream(in, path);
  cv::FileStorage fs = OpenYamlText(text, path);
  const cv::FileNode root = fs.root();
  if (!root.isMap()) throw InputError(InputLocation::File(path), "top level is not a YAML map");

  static const std::set<std::string> kKeys = {"format", "rectified", "image_width", "image_height", "K_left",
                                              "D_left", "K_right",   "D_right",     "R_right_left", "t_right_left"};
  for (const std::string& k : root.keys())
    if (!kKeys.count(k)) throw InputError(InputLocation::File(path), "unknown key '" + k + "'");

  const cv::FileNode fmt = root["format"];
  if (!fmt.isString()) throw InputError(InputLocation::File(path), "missing key 'format'");
  if (fmt.string() != kNativeCalibrationFormat)
    throw InputError(InputLocation::File(path),
                     "format = '" + fmt.string() + "', expected '" + kNativeCalibrationFormat + "'");
  StereoCalibration c;
  c.source_path = path;
  const int rectified = RequireInt(root, "rectified", path);
  if (rectified != 0 && rectified != 1)
    throw InputError(InputLocation::File(path), "rectified = " + std::to_string(rectified) + ", expected 0 or 1");
  c.rectified = rectified == 1;
  c.left.width = c.right.width = RequireInt(root, "image_width", path);
  c.left.height = c.right.height = RequireInt(root, "image_height", path);
  if (c.left.width <= 0 || c.left.height <= 0)
    throw InputError(InputLocation::File(path), "image_width/image_height must be positive");
  ReadCamera(root, "left", path, &c.left);
  ReadCamera(root, "right", path, &c.right);
  const std::vector<double> R = RequireNumbers(root, "R_right_left", path, 9);
  std::copy(R.begin(), R.end(), c.R_right_left.begin());
  const std::vector<double> t = RequireNumbers(root, "t_right_left", path, 3);
  std::copy(t.begin(), t.end(), c.t_right_left.begin());
  CheckStereoCalibration(c, path);
  return c;
}

StereoCalibration ReadCalibrationYaml(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open calibration file");
  return ReadCalibrationYaml(in, path.string());
}

}  // namespace rs
