#include "formats/stereo/calibration_readers.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <regex>
#include <sstream>

#include "formats/input_error.h"
#include "formats/stereo/calibration_check.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/opencv_yaml.h"

namespace rs {

using stereo_internal::OpenYamlText;
using stereo_internal::RequireInt;
using stereo_internal::RequireNumbers;
using stereo_internal::RequireReal;
using stereo_internal::SlurpFile;
using stereo_internal::SlurpStream;

namespace {

[[noreturn]] void Fail(const std::string& path, const std::string& msg) {
  throw InputError(InputLocation::File(path), msg);
}

cv::Matx33d Mat33(const std::vector<double>& v) { return cv::Matx33d(v.data()); }

/// Pinhole intrinsics from a row-major 3x3 K; rejects skew and a bad bottom row.
CameraIntrinsics FromK(const std::vector<double>& K, const std::string& name, const std::string& path) {
  if (K.size() < 9 || K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1)
    Fail(path, name + " must be [fx 0 cx; 0 fy cy; 0 0 1]");
  CameraIntrinsics c;
  c.fx = K[0];
  c.cx = K[2];
  c.fy = K[4];
  c.cy = K[5];
  return c;
}

void SetDistortion(const std::vector<double>& d, const std::string& name, const std::string& path,
                   CameraIntrinsics* c) {
  if (d.size() != 4 && d.size() != 5)
    Fail(path, name + " holds " + std::to_string(d.size()) + " coefficients, expected 4 (k1 k2 p1 p2) or 5 (+k3)");
  c->dist = {};
  std::copy(d.begin(), d.end(), c->dist.begin());
}

void SetExtrinsics(const cv::Matx33d& R, const cv::Vec3d& t, StereoCalibration* c) {
  for (int i = 0; i < 9; ++i) c->R_right_left[i] = R.val[i];
  for (int i = 0; i < 3; ++i) c->t_right_left[i] = t[i];
}

/// Raw calibration behind a stereoRectify result: the rectified cameras differ by a pure
/// x translation Tx = P2[0,3] / P2[0,0]; p_rect_i = R_i p_i, so p_right = R2^T (R1 p_left + (Tx,0,0)).
void FromRectification(const cv::Matx33d& R1, const cv::Matx33d& R2, double Tx, StereoCalibration* c) {
  const cv::Matx33d R = R2.t() * R1;
  const cv::Vec3d t = R2.t() * cv::Vec3d(Tx, 0, 0);
  SetExtrinsics(R, t, c);
  const auto Rn = NearestRotation(c->R_right_left);  // printed R_i carry ~1e-9 rounding
  c->R_right_left = Rn;
}

/// Rotation part of a row-major 4x4 transform, after checking its bottom row.
void SplitTransform(const std::vector<double>& T, const std::string& name, const std::string& path, cv::Matx33d* R,
                    cv::Vec3d* t) {
  if (T.size() != 16) Fail(path, name + " must be a 4x4 transform");
  if (std::abs(T[12]) > 1e-9 || std::abs(T[13]) > 1e-9 || std::abs(T[14]) > 1e-9 || std::abs(T[15] - 1) > 1e-9)
    Fail(path, name + " bottom row is not [0 0 0 1]");
  *R = cv::Matx33d(T[0], T[1], T[2], T[4], T[5], T[6], T[8], T[9], T[10]);
  *t = cv::Vec3d(T[3], T[7], T[11]);
  // Check each input rotation before composing, so the error names the key that is wrong.
  std::array<double, 9> r;
  for (int i = 0; i < 9; ++i) r[i] = R->val[i];
  StereoCalibration probe;
  probe.R_right_left = r;
  probe.t_right_left = {-1, 0, 0};
  probe.left.fx = probe.left.fy = probe.right.fx = probe.right.fy = 1;
  CalibrationLimits lim;
  lim.rotation_tolerance = 1e-4;  // Kalibr/KAIST print 5 decimals
  try {
    CheckStereoCalibration(probe, path, lim);
  } catch (const InputError& e) {
    Fail(path, name + ": " + e.message());
  }
}

/// Composition of two camera poses in a common frame (body/IMU): T_c1_c0 = T_b_c1^-1 * T_b_c0.
void FromBodyPoses(const cv::Matx33d& R_b_c0, const cv::Vec3d& t_b_c0, const cv::Matx33d& R_b_c1,
                   const cv::Vec3d& t_b_c1, StereoCalibration* c) {
  const cv::Matx33d R = R_b_c1.t() * R_b_c0;
  const cv::Vec3d t = R_b_c1.t() * (t_b_c0 - t_b_c1);
  SetExtrinsics(R, t, c);
  c->R_right_left = NearestRotation(c->R_right_left);
}

// Projection-matrix pair of rectified cameras (KITTI): K shared, t_i = K^-1 P_i[:,3].
StereoCalibration FromProjections(const std::vector<double>& Pl, const std::vector<double>& Pr,
                                  const std::string& left_name, const std::string& right_name, const std::string& path,
                                  int width, int height) {
  auto K_of = [](const std::vector<double>& P) {
    return std::vector<double>{P[0], P[1], P[2], P[4], P[5], P[6], P[8], P[9], P[10]};
  };
  const std::vector<double> Kl = K_of(Pl), Kr = K_of(Pr);
  StereoCalibration c;
  c.left = FromK(Kl, left_name + " (left 3x3)", path);
  c.right = FromK(Kr, right_name + " (left 3x3)", path);
  for (int i = 0; i < 9; ++i)
    if (std::abs(Kl[i] - Kr[i]) > 1e-9 * std::max(1.0, std::abs(Kl[i])))
      Fail(path, left_name + " and " + right_name + " have different intrinsics: not a rectified pair");
  c.left.width = c.right.width = width;
  c.left.height = c.right.height = height;
  const cv::Matx33d Kinv = Mat33(Kl).inv();
  const cv::Vec3d tl = Kinv * cv::Vec3d(Pl[3], Pl[7], Pl[11]);
  const cv::Vec3d tr = Kinv * cv::Vec3d(Pr[3], Pr[7], Pr[11]);
  const cv::Vec3d d = tr - tl;
  // KITTI raw P_rect_02/03 carry a few mm of y/z offset; like the KITTI devkit we keep the
  // x baseline only, and refuse pairs where the rest is not small.
  if (std::abs(d[1]) > 0.02 * std::abs(d[0]) || std::abs(d[2]) > 0.02 * std::abs(d[0]))
    Fail(path, left_name + "/" + right_name + " are not a horizontally rectified pair (translation " +
                   std::to_string(d[0]) + ", " + std::to_string(d[1]) + ", " + std::to_string(d[2]) + " m)");
  c.t_right_left = {d[0], 0, 0};
  c.rectified = true;
  return c;
}

// ---- yaml-cpp helpers (stella_vslam files are plain YAML that cv::FileStorage cannot parse) ----

/// Parses YAML with yaml-cpp. OpenCV-style "%YAML:1.0" first lines (OpenVINS' Kalibr files)
/// are not YAML 1.2 directives: they are blanked, keeping line numbers.
YAML::Node YLoad(std::string text, const std::string& path) {
  if (text.rfind("%YAML:", 0) == 0) text[0] = '#';
  try {
    return YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(InputLocation::Line(path, e.mark.line + 1), "YAML parse error: " + e.msg);
  }
}

std::string YString(const YAML::Node& parent, const std::string& key) {
  if (!parent.IsMap() || !parent[key] || !parent[key].IsScalar()) return "?";
  return parent[key].Scalar();
}

YAML::Node YRequire(const YAML::Node& parent, const std::string& key, const std::string& key_path,
                    const std::string& path) {
  if (!parent.IsMap() || !parent[key]) Fail(path, "missing key '" + key_path + "'");
  return parent[key];
}

double YReal(const YAML::Node& parent, const std::string& key, const std::string& key_path, const std::string& path) {
  const YAML::Node n = YRequire(parent, key, key_path, path);
  try {
    return n.as<double>();
  } catch (const YAML::Exception&) {
    throw InputError(InputLocation::Line(path, n.Mark().line + 1), "key '" + key_path + "' is not a number");
  }
}

std::vector<double> YNumbers(const YAML::Node& parent, const std::string& key, const std::string& key_path,
                             const std::string& path, size_t expected) {
  const YAML::Node n = YRequire(parent, key, key_path, path);
  try {
    std::vector<double> v;
    if (n.IsSequence() && n.size() > 0 && n[0].IsSequence()) {  // Kalibr's 4x4 as rows
      for (const auto& row : n)
        for (double x : row.as<std::vector<double>>()) v.push_back(x);
    } else {
      v = n.as<std::vector<double>>();
    }
    if (expected > 0 && v.size() != expected)
      throw InputError(
          InputLocation::Line(path, n.Mark().line + 1),
          "key '" + key_path + "' holds " + std::to_string(v.size()) + " values, expected " + std::to_string(expected));
    return v;
  } catch (const YAML::Exception&) {
    throw InputError(InputLocation::Line(path, n.Mark().line + 1), "key '" + key_path + "' is not a list of numbers");
  }
}

// ---- KITTI text files: "NAME: v v v ..." ----

struct KittiEntry {
  std::vector<double> values;
  int64_t line = 0;
};

std::map<std::string, KittiEntry> ParseKittiText(std::istream& in, const std::string& path, bool allow_unlabelled) {
  std::map<std::string, KittiEntry> out;
  std::string line;
  int64_t line_no = 0, unlabelled = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    std::string name;
    std::string rest = line;
    const size_t colon = line.find(':');
    if (colon != std::string::npos) {
      name = line.substr(0, colon);
      rest = line.substr(colon + 1);
    } else if (allow_unlabelled) {
      name = "P" + std::to_string(unlabelled++);
    } else {
      throw InputError(InputLocation::Line(path, line_no), "expected 'NAME: values'");
    }
    KittiEntry e;
    e.line = line_no;
    std::istringstream s(rest);
    std::string tok;
    bool numeric = true;
    while (s >> tok) {
      char* end = nullptr;
      const double v = std::strtod(tok.c_str(), &end);
      if (end != tok.c_str() + tok.size() || !std::isfinite(v)) {
        numeric = false;
        break;
      }
      e.values.push_back(v);
    }
    if (!numeric) {
      if (name == "calib_time") continue;  // "09-Jan-2012 13:57:47"
      throw InputError(InputLocation::Line(path, line_no), "'" + name + "' holds a non-numeric value '" + tok + "'");
    }
    out[name] = std::move(e);
  }
  if (in.bad()) Fail(path, "read error");
  return out;
}

const std::vector<double>& KittiRequire(const std::map<std::string, KittiEntry>& m, const std::string& key,
                                        size_t expected, const std::string& path) {
  auto it = m.find(key);
  if (it == m.end()) Fail(path, "missing '" + key + "'");
  if (it->second.values.size() != expected)
    throw InputError(InputLocation::Line(path, it->second.line), "'" + key + "' holds " +
                                                                     std::to_string(it->second.values.size()) +
                                                                     " values, expected " + std::to_string(expected));
  return it->second.values;
}

std::string Cam2(int i) { return (i < 10 ? "0" : "") + std::to_string(i); }

}  // namespace

StereoCalibration ReadOrbSlam2Settings(std::istream& in, const std::string& path) {
  cv::FileStorage fs = OpenYamlText(SlurpStream(in, path), path);
  const cv::FileNode root = fs.root();
  if (root["Camera.fx"].empty()) Fail(path, "missing key 'Camera.fx': not ORB-SLAM2 settings");
  if (root["Camera.bf"].empty()) Fail(path, "no 'Camera.bf': monocular ORB-SLAM2 settings, not a stereo calibration");
  const double fx = RequireReal(root, "Camera.fx", path);
  const double bf = RequireReal(root, "Camera.bf", path);
  StereoCalibration c;
  c.source_path = path;
  if (!root["LEFT.K"].empty()) {
    c.left = FromK(RequireNumbers(root, "LEFT.K", path, 9), "LEFT.K", path);
    c.right = FromK(RequireNumbers(root, "RIGHT.K", path, 9), "RIGHT.K", path);
    SetDistortion(RequireNumbers(root, "LEFT.D", path, 0), "LEFT.D", path, &c.left);
    SetDistortion(RequireNumbers(root, "RIGHT.D", path, 0), "RIGHT.D", path, &c.right);
    c.left.width = RequireInt(root, "LEFT.width", path);
    c.left.height = RequireInt(root, "LEFT.height", path);
    c.right.width = RequireInt(root, "RIGHT.width", path);
    c.right.height = RequireInt(root, "RIGHT.height", path);
    const std::vector<double> P2 = RequireNumbers(root, "RIGHT.P", path, 12);
    if (P2[0] <= 0) Fail(path, "RIGHT.P[0,0] must be positive");
    FromRectification(Mat33(RequireNumbers(root, "LEFT.R", path, 9)), Mat33(RequireNumbers(root, "RIGHT.R", path, 9)),
                      P2[3] / P2[0], &c);
    c.rectified = false;
  } else {
    c.left.fx = fx;
    c.left.fy = RequireReal(root, "Camera.fy", path);
    c.left.cx = RequireReal(root, "Camera.cx", path);
    c.left.cy = RequireReal(root, "Camera.cy", path);
    c.left.width = RequireInt(root, "Camera.width", path);
    c.left.height = RequireInt(root, "Camera.height", path);
    for (const char* k : {"Camera.k1", "Camera.k2", "Camera.p1", "Camera.p2", "Camera.k3"})
      if (!root[k].empty() && RequireReal(root, k, path) != 0)
        Fail(path, std::string(k) + " is not zero, but settings without LEFT/RIGHT blocks describe rectified images");
    c.right = c.left;
    if (fx <= 0) Fail(path, "Camera.fx must be positive");
    c.t_right_left = {-bf / fx, 0, 0};
    c.rectified = true;
  }
  CheckStereoCalibration(c, path);
  return c;
}

StereoCalibration ReadStellaVslamSettings(std::istream& in, const std::string& path) {
  const YAML::Node root = YLoad(SlurpStream(in, path), path);
  const YAML::Node cam = YRequire(root, "Camera", "Camera", path);
  if (cam["setup"] && cam["setup"].as<std::string>("") != "stereo")
    Fail(path, "Camera.setup = '" + cam["setup"].as<std::string>("") + "': not a stereo setup");
  if (cam["model"] && cam["model"].as<std::string>("") != "perspective")
    Fail(path, "Camera.model = '" + cam["model"].as<std::string>("") + "': only 'perspective' is supported");
  const double fx = YReal(cam, "fx", "Camera.fx", path);
  const double fxb = YReal(cam, "focal_x_baseline", "Camera.focal_x_baseline", path);
  if (fx <= 0) Fail(path, "Camera.fx must be positive");
  const int cols = static_cast<int>(YReal(cam, "cols", "Camera.cols", path));
  const int rows = static_cast<int>(YReal(cam, "rows", "Camera.rows", path));
  StereoCalibration c;
  c.source_path = path;
  if (root["StereoRectifier"]) {
    const YAML::Node r = root["StereoRectifier"];
    c.left = FromK(YNumbers(r, "K_left", "StereoRectifier.K_left", path, 9), "StereoRectifier.K_left", path);
    c.right = FromK(YNumbers(r, "K_right", "StereoRectifier.K_right", path, 9), "StereoRectifier.K_right", path);
    SetDistortion(YNumbers(r, "D_left", "StereoRectifier.D_left", path, 0), "StereoRectifier.D_left", path, &c.left);
    SetDistortion(YNumbers(r, "D_right", "StereoRectifier.D_right", path, 0), "StereoRectifier.D_right", path,
                  &c.right);
    c.left.width = c.right.width = cols;
    c.left.height = c.right.height = rows;
    // stella's rectified right projection is P2 = [fx 0 cx -focal_x_baseline; ...].
    FromRectification(Mat33(YNumbers(r, "R_left", "StereoRectifier.R_left", path, 9)),
                      Mat33(YNumbers(r, "R_right", "StereoRectifier.R_right", path, 9)), -fxb / fx, &c);
    c.rectified = false;
  } else {
    c.left.fx = fx;
    c.left.fy = YReal(cam, "fy", "Camera.fy", path);
    c.left.cx = YReal(cam, "cx", "Camera.cx", path);
    c.left.cy = YReal(cam, "cy", "Camera.cy", path);
    c.left.width = cols;
    c.left.height = rows;
    for (const char* k : {"k1", "k2", "p1", "p2", "k3"})
      if (cam[k] && YReal(cam, k, std::string("Camera.") + k, path) != 0)
        Fail(path, std::string("Camera.") + k + " is not zero, but settings without StereoRectifier are rectified");
    c.right = c.left;
    c.t_right_left = {-fxb / fx, 0, 0};
    c.rectified = true;
  }
  CheckStereoCalibration(c, path);
  return c;
}

namespace {

CameraIntrinsics KalibrCamera(const YAML::Node& cam, const std::string& name, const std::string& path) {
  if (YString(cam, "camera_model") != "pinhole")
    Fail(path, name + ".camera_model = '" + YString(cam, "camera_model") + "': only 'pinhole' is supported");
  if (YString(cam, "distortion_model") != "radtan")
    Fail(path, name + ".distortion_model = '" + YString(cam, "distortion_model") + "': only 'radtan' is supported");
  const std::vector<double> k = YNumbers(cam, "intrinsics", name + ".intrinsics", path, 4);
  CameraIntrinsics c;
  c.fx = k[0];
  c.fy = k[1];
  c.cx = k[2];
  c.cy = k[3];
  SetDistortion(YNumbers(cam, "distortion_coeffs", name + ".distortion_coeffs", path, 0), name + ".distortion_coeffs",
                path, &c);
  const std::vector<double> res = YNumbers(cam, "resolution", name + ".resolution", path, 2);
  c.width = static_cast<int>(res[0]);
  c.height = static_cast<int>(res[1]);
  return c;
}

void KalibrTransform(const YAML::Node& cam, const std::string& cam_name, const std::string& key,
                     const std::string& path, cv::Matx33d* R, cv::Vec3d* t) {
  const std::string name = cam_name + "." + key;
  SplitTransform(YNumbers(cam, key, name, path, 16), name, path, R, t);
}

}  // namespace

StereoCalibration ReadKalibrCamchain(std::istream& in, const std::string& path) {
  const YAML::Node root = YLoad(SlurpStream(in, path), path);
  if (!root.IsMap()) Fail(path, "top level is not a YAML map: not a Kalibr camchain");
  const YAML::Node c0 = root["cam0"], c1 = root["cam1"];
  if (!c0 && root["imu0"]) Fail(path, "Kalibr IMU chain: holds no cameras");
  if (!c0) Fail(path, "missing key 'cam0': not a Kalibr camchain");
  if (!c1) Fail(path, "missing key 'cam1': a single-camera chain is not a stereo calibration");
  StereoCalibration c;
  c.source_path = path;
  c.left = KalibrCamera(c0, "cam0", path);
  c.right = KalibrCamera(c1, "cam1", path);
  cv::Matx33d R0, R1;
  cv::Vec3d t0, t1;
  if (c1["T_cn_cnm1"]) {
    KalibrTransform(c1, "cam1", "T_cn_cnm1", path, &R1, &t1);
    SetExtrinsics(R1, t1, &c);
    c.R_right_left = NearestRotation(c.R_right_left);
  } else if (c0["T_cam_imu"] && c1["T_cam_imu"]) {
    // T_c_i maps IMU points into the camera: the body pose of camera c is its inverse.
    KalibrTransform(c0, "cam0", "T_cam_imu", path, &R0, &t0);
    KalibrTransform(c1, "cam1", "T_cam_imu", path, &R1, &t1);
    FromBodyPoses(R0.t(), -(R0.t() * t0), R1.t(), -(R1.t() * t1), &c);
  } else if (c0["T_imu_cam"] && c1["T_imu_cam"]) {
    KalibrTransform(c0, "cam0", "T_imu_cam", path, &R0, &t0);
    KalibrTransform(c1, "cam1", "T_imu_cam", path, &R1, &t1);
    FromBodyPoses(R0, t0, R1, t1, &c);
  } else {
    Fail(path, "no extrinsics: expected cam1.T_cn_cnm1, or T_cam_imu / T_imu_cam on both cameras");
  }
  CheckStereoCalibration(c, path);
  return c;
}

namespace {

CameraIntrinsics EurocCamera(const cv::FileNode& root, const std::string& path, cv::Matx33d* R_b_c, cv::Vec3d* t_b_c) {
  const cv::FileNode type = root["sensor_type"];
  if (!type.isString() || type.string() != "camera") Fail(path, "sensor_type is not 'camera'");
  const cv::FileNode model = root["camera_model"];
  if (!model.isString() || model.string() != "pinhole") Fail(path, "camera_model: only 'pinhole' is supported");
  const cv::FileNode dm = root["distortion_model"];
  if (!dm.isString() || (dm.string() != "radial-tangential" && dm.string() != "radtan"))
    Fail(path, "distortion_model: only 'radial-tangential' is supported");
  const std::vector<double> k = RequireNumbers(root, "intrinsics", path, 4);
  CameraIntrinsics c;
  c.fx = k[0];
  c.fy = k[1];
  c.cx = k[2];
  c.cy = k[3];
  SetDistortion(RequireNumbers(root, "distortion_coefficients", path, 0), "distortion_coefficients", path, &c);
  const std::vector<double> res = RequireNumbers(root, "resolution", path, 2);
  c.width = static_cast<int>(res[0]);
  c.height = static_cast<int>(res[1]);
  SplitTransform(RequireNumbers(root, "T_BS", path, 16), "T_BS", path, R_b_c, t_b_c);
  return c;
}

}  // namespace

StereoCalibration ReadEurocSensorPair(const std::filesystem::path& left_yaml, const std::filesystem::path& right_yaml) {
  const std::string lp = left_yaml.string(), rp = right_yaml.string();
  cv::FileStorage fl = OpenYamlText(SlurpFile(lp), lp);
  cv::FileStorage fr = OpenYamlText(SlurpFile(rp), rp);
  StereoCalibration c;
  c.source_path = lp;
  cv::Matx33d R0, R1;
  cv::Vec3d t0, t1;
  c.left = EurocCamera(fl.root(), lp, &R0, &t0);
  c.right = EurocCamera(fr.root(), rp, &R1, &t1);
  FromBodyPoses(R0, t0, R1, t1, &c);
  CheckStereoCalibration(c, lp + " + " + rp);
  return c;
}

StereoCalibration ReadKittiOdometryCalib(std::istream& in, const std::string& path, int width, int height,
                                         int left_index, int right_index) {
  const auto m = ParseKittiText(in, path, /*allow_unlabelled=*/true);
  const std::string ln = "P" + std::to_string(left_index), rn = "P" + std::to_string(right_index);
  StereoCalibration c =
      FromProjections(KittiRequire(m, ln, 12, path), KittiRequire(m, rn, 12, path), ln, rn, path, width, height);
  c.source_path = path;
  CheckStereoCalibration(c, path);
  return c;
}

StereoCalibration ReadKittiRawCamToCam(std::istream& in, const std::string& path, bool rectified, int left_cam,
                                       int right_cam) {
  const auto m = ParseKittiText(in, path, /*allow_unlabelled=*/false);
  const std::string l = Cam2(left_cam), r = Cam2(right_cam);
  StereoCalibration c;
  if (rectified) {
    const std::vector<double>& S = KittiRequire(m, "S_rect_" + l, 2, path);
    KittiRequire(m, "S_rect_" + r, 2, path);
    c = FromProjections(KittiRequire(m, "P_rect_" + l, 12, path), KittiRequire(m, "P_rect_" + r, 12, path),
                        "P_rect_" + l, "P_rect_" + r, path, static_cast<int>(S[0]), static_cast<int>(S[1]));
  } else {
    for (const auto& [cam, side] : {std::pair{l, &c.left}, std::pair{r, &c.right}}) {
      *side = FromK(KittiRequire(m, "K_" + cam, 9, path), "K_" + cam, path);
      SetDistortion(KittiRequire(m, "D_" + cam, 5, path), "D_" + cam, path, side);
      const std::vector<double>& S = KittiRequire(m, "S_" + cam, 2, path);
      side->width = static_cast<int>(S[0]);
      side->height = static_cast<int>(S[1]);
    }
    // R_0x, T_0x map camera-0 points into camera x.
    const cv::Matx33d Rl = Mat33(KittiRequire(m, "R_" + l, 9, path)), Rr = Mat33(KittiRequire(m, "R_" + r, 9, path));
    const std::vector<double>& Tl = KittiRequire(m, "T_" + l, 3, path);
    const std::vector<double>& Tr = KittiRequire(m, "T_" + r, 3, path);
    const cv::Matx33d R = Rr * Rl.t();
    const cv::Vec3d t = cv::Vec3d(Tr[0], Tr[1], Tr[2]) - R * cv::Vec3d(Tl[0], Tl[1], Tl[2]);
    SetExtrinsics(R, t, &c);
    c.R_right_left = NearestRotation(c.R_right_left);  // printed with 7 digits
  }
  c.source_path = path;
  CheckStereoCalibration(c, path);
  return c;
}

std::string ToString(CalibrationFormat f) {
  switch (f) {
    case CalibrationFormat::kNative: return "roadsurvey calibration.yaml";
    case CalibrationFormat::kOrbSlam2: return "ORB-SLAM2 settings";
    case CalibrationFormat::kStellaVslam: return "stella_vslam settings";
    case CalibrationFormat::kKalibr: return "Kalibr camchain";
    case CalibrationFormat::kEurocSensor: return "EuRoC sensor.yaml pair";
    case CalibrationFormat::kKittiOdometry: return "KITTI odometry calib.txt";
    case CalibrationFormat::kKittiRaw: return "KITTI raw calib_cam_to_cam.txt";
  }
  return "?";
}

StereoCalibration ReadStereoCalibration(const std::filesystem::path& path, CalibrationFormat* format_out) {
  const std::string p = path.string();
  if (std::filesystem::is_directory(path)) Fail(p, "is a folder; expected a calibration file");
  const std::string text = SlurpFile(p);
  auto has = [&](const char* re) { return std::regex_search(text, std::regex(re, std::regex::multiline)); };
  auto set = [&](CalibrationFormat f) {
    if (format_out) *format_out = f;
  };
  std::istringstream in(text);
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    if (text.find("\"camera_type\"") != std::string::npos)
      Fail(p, "basalt JSON calibration: not supported (its camera models, e.g. double-sphere, are not pinhole)");
    Fail(p, "JSON file is not a recognised stereo calibration");
  }
  if (text.find(kNativeCalibrationFormat) != std::string::npos) {
    set(CalibrationFormat::kNative);
    return ReadCalibrationYaml(in, p);
  }
  if (has(R"(^sensor_type:\s*camera)")) {
    set(CalibrationFormat::kEurocSensor);
    const std::filesystem::path dir = path.parent_path();
    const std::string cam = dir.filename().string();
    if (cam == "cam0") return ReadEurocSensorPair(path, dir.parent_path() / "cam1" / path.filename());
    if (cam == "cam1") return ReadEurocSensorPair(dir.parent_path() / "cam0" / path.filename(), path);
    Fail(p, "EuRoC sensor.yaml outside a cam0/ or cam1/ folder: cannot find the other camera of the pair");
  }
  if (has(R"(^(P_rect_|S_rect_)\d\d:)")) {
    set(CalibrationFormat::kKittiRaw);
    return ReadKittiRawCamToCam(in, p);
  }
  if (has(R"(^Camera\.fx:)")) {
    set(CalibrationFormat::kOrbSlam2);
    return ReadOrbSlam2Settings(in, p);
  }
  if (has(R"(^Camera:\s*$)")) {
    set(CalibrationFormat::kStellaVslam);
    return ReadStellaVslamSettings(in, p);
  }
  if (has(R"(^cam0:\s*$)") || has(R"(^imu0:\s*$)")) {
    set(CalibrationFormat::kKalibr);
    return ReadKalibrCamchain(in, p);
  }
  if (has(R"(^P0:)") || has(R"(^[ \t]*[-+0-9.eE]+([ \t]+[-+0-9.eE]+){11}[ \t]*$)")) {
    set(CalibrationFormat::kKittiOdometry);
    return ReadKittiOdometryCalib(in, p);
  }
  Fail(p,
       "unrecognised calibration format (expected calibration.yaml, ORB-SLAM2/stella_vslam settings, "
       "Kalibr camchain, EuRoC sensor.yaml, KITTI calib.txt or calib_cam_to_cam.txt)");
}

}  // namespace rs
