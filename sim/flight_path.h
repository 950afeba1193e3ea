#pragma once
// The platform's true motion: follows the road centreline at a set height with
// realistic wobble (lateral, height, attitude); optionally out and back.
// Body frame FRD (x forward, y right, z down); body origin = left camera centre
// = GNSS antenna (zero lever arms, so the log and the truth describe one point).

#include <Eigen/Geometry>

#include "sim/road_scene.h"
#include "sim/simulation_options.h"

namespace rs::sim {

/// True platform state at one instant.
struct PlatformState {
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();  ///< world = local ENU
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();               ///< velocity, m/s
  double s_m = 0;                                                  ///< road distance under the platform
};

class FlightPath {
 public:
  FlightPath(const SimulationOptions& o, const RoadGeometry& road);

  /// State at t_s seconds after the first frame (true time; may be negative).
  PlatformState At(double t_s) const;
  /// Left camera pose at t_s: T_world_body * T_body_cam.
  Eigen::Isometry3d T_world_cam(double t_s) const { return At(t_s).T_world_body * T_body_cam_; }
  /// Camera mount: OpenCV camera axes (x right, y down, z optical axis) in the body frame.
  const Eigen::Isometry3d& T_body_cam() const { return T_body_cam_; }
  /// The camera mount: left camera axes (OpenCV) in the body FRD frame for an optical axis
  /// `camera_pitch_deg` below the forward axis (90 = nadir).
  static Eigen::Matrix3d MountRotation(double camera_pitch_deg);
  /// Range of road distance the flight covers (first and last frame, both legs).
  double s_first() const { return s_first_; }
  double s_last_max() const { return s_far_; }

 private:
  double RoadS(double t, double* heading_offset) const;
  double Wobble(int channel, double t) const;

  const RoadGeometry& road_;
  SimulationOptions o_;
  Eigen::Isometry3d T_body_cam_ = Eigen::Isometry3d::Identity();
  double amp_[6];  // lateral m, height m, yaw rad, pitch rad, roll rad, along-track m
  double freq_[6][3], phase_[6][3];
  double s_first_ = 0, s_far_ = 0, t_out_ = 0;
};

}  // namespace rs::sim
