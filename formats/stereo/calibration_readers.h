#pragma once
// Readers for the stereo calibration files of public datasets and SLAM systems,
// each converted into StereoCalibration (left = reference camera, OpenCV
// stereoCalibrate convention) and checked with CheckStereoCalibration.
// Formats and conversions: docs/formats/stereo-sources.md.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/stereo_calibration.h"

namespace rs {

/// ORB-SLAM2 stereo settings (OpenCV YAML, "Camera.fx", "Camera.bf", ...). With
/// LEFT.K/D/R/P and RIGHT.K/D/R/P blocks (EuRoC) the raw, unrectified calibration is
/// recovered: R_right_left = RIGHT.R^T * LEFT.R, t_right_left = RIGHT.R^T * (P2[0,3]/P2[0,0], 0, 0).
/// Without them (KITTI) the pair is already rectified: K from Camera.*, baseline = bf / fx.
/// Monocular settings (no Camera.bf) are rejected.
StereoCalibration ReadOrbSlam2Settings(std::istream& in, const std::string& path_for_errors);

/// stella_vslam / OpenVSLAM YAML ("Camera:" map with setup: stereo, fx.., cols, rows,
/// focal_x_baseline; optional "StereoRectifier:" K_left, D_left, R_left, K_right, ...).
/// Same conversion as ReadOrbSlam2Settings.
StereoCalibration ReadStellaVslamSettings(std::istream& in, const std::string& path_for_errors);

/// Kalibr camchain (cam0, cam1: camera_model pinhole, distortion_model radtan, intrinsics
/// [fu fv cu cv], resolution [w h]). Extrinsics from cam1.T_cn_cnm1 (p_cam1 = T * p_cam0),
/// else from T_cam_imu of both cameras, else from T_imu_cam (OpenVINS' variant).
StereoCalibration ReadKalibrCamchain(std::istream& in, const std::string& path_for_errors);

/// A pair of EuRoC/ASL sensor.yaml files (T_BS = T_body_cam, intrinsics [fu fv cu cv],
/// radial-tangential distortion). left_yaml is cam0, right_yaml cam1.
StereoCalibration ReadEurocSensorPair(const std::filesystem::path& left_yaml, const std::filesystem::path& right_yaml);

/// KITTI odometry calib.txt: lines "P0: <12 numbers>" .. "P3: ..." (or, as some copies
/// ship it, unlabelled lines in that order). The pair (left_index, right_index) is taken,
/// default the grey cameras P0/P1. Images are rectified: K from P_left, baseline from the
/// difference of K^-1 * P[:,3]; image size is not in the file, pass it (0 = unknown).
StereoCalibration ReadKittiOdometryCalib(std::istream& in, const std::string& path_for_errors, int image_width = 0,
                                         int image_height = 0, int left_index = 0, int right_index = 1);

/// KITTI raw calib_cam_to_cam.txt for cameras left_cam/right_cam (default the colour pair
/// 02/03). rectified = true: for "*_sync" images (P_rect_0x, S_rect_0x); false: for raw
/// "*_extract" images (K_0x, D_0x, R_0x, T_0x, S_0x).
StereoCalibration ReadKittiRawCamToCam(std::istream& in, const std::string& path_for_errors, bool rectified = true,
                                       int left_cam = 2, int right_cam = 3);

/// The calibration formats ReadStereoCalibration recognises.
enum class CalibrationFormat { kNative, kOrbSlam2, kStellaVslam, kKalibr, kEurocSensor, kKittiOdometry, kKittiRaw };

/// Human-readable format name ("kalibr camchain", ...).
std::string ToString(CalibrationFormat f);

/// Recognises the format from the file's content and reads it. EuRoC sensor.yaml is
/// paired with ../cam1/sensor.yaml (or ../cam0 for cam1's file). Unsupported files
/// (monocular settings, IMU-only chains, non-pinhole models, basalt JSON) throw
/// InputError saying why. format_out, when non-null, receives the detected format.
StereoCalibration ReadStereoCalibration(const std::filesystem::path& path, CalibrationFormat* format_out = nullptr);

}  // namespace rs
