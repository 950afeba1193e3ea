#include "formats/stereo/calibration_check.h"

#include <cmath>
#include <opencv2/core.hpp>
#include <sstream>

#include "formats/input_error.h"

namespace rs {
namespace {

std::string Num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

void CheckCamera(const CameraIntrinsics& c, const std::string& side, const std::string& path,
                 const CalibrationLimits& lim) {
  auto fail = [&](const std::string& msg) { throw InputError(InputLocation::File(path), msg); };
  const std::string k = "K_" + side;
  if (c.width < 0 || c.height < 0)
    fail("image size " + std::to_string(c.width) + "x" + std::to_string(c.height) + " of " + side +
         " camera violates width, height >= 0");
  for (auto [name, v] : {std::pair{"fx", c.fx}, std::pair{"fy", c.fy}}) {
    if (!std::isfinite(v) || v <= 0) fail(k + "." + name + " = " + Num(v) + " violates " + name + " > 0");
    if (v > lim.max_focal_px)
      fail(k + "." + name + " = " + Num(v) + " violates " + name + " <= " + Num(lim.max_focal_px) + " px");
  }
  if (!std::isfinite(c.cx) || !std::isfinite(c.cy)) fail(k + " principal point is not finite");
  const double m = lim.principal_point_margin;
  if (c.width > 0 && (c.cx < -m * c.width || c.cx > (1 + m) * c.width))
    fail(k + ".cx = " + Num(c.cx) + " lies far outside the image (width " + std::to_string(c.width) + ")");
  if (c.height > 0 && (c.cy < -m * c.height || c.cy > (1 + m) * c.height))
    fail(k + ".cy = " + Num(c.cy) + " lies far outside the image (height " + std::to_string(c.height) + ")");
  for (size_t i = 0; i < c.dist.size(); ++i)
    if (!std::isfinite(c.dist[i]) || std::abs(c.dist[i]) > 1e3)
      fail("D_" + side + "[" + std::to_string(i) + "] = " + Num(c.dist[i]) +
           " is not a plausible distortion coefficient");
}

}  // namespace

void CheckStereoCalibration(const StereoCalibration& calib, const std::string& path, const CalibrationLimits& lim) {
  auto fail = [&](const std::string& msg) { throw InputError(InputLocation::File(path), msg); };
  CheckCamera(calib.left, "left", path, lim);
  CheckCamera(calib.right, "right", path, lim);

  const auto& R = calib.R_right_left;
  for (double v : R)
    if (!std::isfinite(v)) fail("R_right_left has a non-finite element");
  double worst = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double d = 0;
      for (int k = 0; k < 3; ++k) d += R[i * 3 + k] * R[j * 3 + k];
      worst = std::max(worst, std::abs(d - (i == j ? 1.0 : 0.0)));
    }
  if (worst > lim.rotation_tolerance)
    fail("R_right_left is not orthonormal: max |R R^T - I| = " + Num(worst) + " > " + Num(lim.rotation_tolerance));
  const double det =
      R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) + R[2] * (R[3] * R[7] - R[4] * R[6]);
  if (std::abs(det - 1) > lim.rotation_tolerance)
    fail("R_right_left has det = " + Num(det) + ", violates det = 1 (a reflection?)");

  for (double v : calib.t_right_left)
    if (!std::isfinite(v)) fail("t_right_left has a non-finite element");
  const double B = calib.BaselineM();
  if (B < lim.min_baseline_m)
    fail("t_right_left: baseline " + Num(B) + " m violates baseline >= " + Num(lim.min_baseline_m) + " m");
  if (B > lim.max_baseline_m)
    fail("t_right_left: baseline " + Num(B) + " m violates baseline <= " + Num(lim.max_baseline_m) +
         " m (millimetres instead of metres?)");

  if (calib.rectified) {
    const auto& L = calib.left;
    const auto& Rt = calib.right;
    if (L.fx != Rt.fx || L.fy != Rt.fy || L.cx != Rt.cx || L.cy != Rt.cy) fail("rectified = 1 but K_left != K_right");
    if (L.width != Rt.width || L.height != Rt.height) fail("rectified = 1 but left and right image sizes differ");
    for (int i = 0; i < 5; ++i)
      if (L.dist[i] != 0 || Rt.dist[i] != 0) fail("rectified = 1 but D_left or D_right is not zero");
    for (int i = 0; i < 9; ++i)
      if (std::abs(R[i] - ((i % 4 == 0) ? 1.0 : 0.0)) > lim.rectified_tolerance)
        fail("rectified = 1 but R_right_left is not the identity");
    const auto& t = calib.t_right_left;
    if (std::abs(t[1]) > lim.rectified_tolerance * B || std::abs(t[2]) > lim.rectified_tolerance * B)
      fail("rectified = 1 but t_right_left is not (-B, 0, 0)");
    if (t[0] >= 0)
      fail("rectified = 1 but t_right_left.x = " + Num(t[0]) + " violates x < 0 (right camera on the right)");
  }
}

std::array<double, 9> NearestRotation(const std::array<double, 9>& R_rowmajor) {
  cv::Matx33d R(R_rowmajor.data());
  cv::Mat w, u, vt;
  cv::SVD::compute(cv::Mat(R), w, u, vt);
  cv::Mat P = u * vt;
  if (cv::determinant(P) < 0) {  // keep a proper rotation; the caller's det check catches reflections first
    cv::Mat d = cv::Mat::eye(3, 3, CV_64F);
    d.at<double>(2, 2) = -1;
    P = u * d * vt;
  }
  std::array<double, 9> out;
  for (int i = 0; i < 9; ++i) out[i] = P.at<double>(i / 3, i % 3);
  return out;
}

}  // namespace rs
