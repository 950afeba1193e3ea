#include "sim/flight_path.h"

#include <algorithm>
#include <cmath>

namespace rs::sim {
namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
}  // namespace

Eigen::Matrix3d FlightPath::MountRotation(double camera_pitch_deg) {
  const double p = camera_pitch_deg * kDeg;
  Eigen::Matrix3d R_body_cam;
  R_body_cam.col(0) = Eigen::Vector3d(0, 1, 0);
  R_body_cam.col(1) = Eigen::Vector3d(-std::sin(p), 0, std::cos(p));
  R_body_cam.col(2) = Eigen::Vector3d(std::cos(p), 0, std::sin(p));
  return R_body_cam;
}

FlightPath::FlightPath(const SimulationOptions& o, const RoadGeometry& road) : road_(road), o_(o) {
  T_body_cam_.linear() = MountRotation(o.camera_pitch_deg);

  const bool car = o.platform == "car";
  const double k = o.wobble_scale;
  const double amps_drone[6] = {0.30, 0.12, 1.5 * kDeg, 1.2 * kDeg, 1.2 * kDeg, 0.15};
  const double amps_car[6] = {0.08, 0.01, 0.4 * kDeg, 0.3 * kDeg, 0.3 * kDeg, 0.05};
  Rng rng(HashCombine(static_cast<uint64_t>(o.seed), 17));
  for (int c = 0; c < 6; ++c) {
    amp_[c] = k * (car ? amps_car[c] : amps_drone[c]);
    for (int i = 0; i < 3; ++i) {
      freq_[c][i] = rng.Uniform(0.05, 0.45);
      phase_[c][i] = rng.Uniform(0, 2 * kPi);
    }
  }
  s_first_ = o.start_s_m;
  const double T = (o.num_frames - 1) / o.frame_rate_hz;
  if (o.out_and_back) {
    s_far_ = o.road_length_m - o.start_s_m;
    t_out_ = (s_far_ - s_first_) / o.speed_m_s;
  } else {
    s_far_ = o.start_s_m + o.speed_m_s * T;
  }
}

double FlightPath::Wobble(int c, double t) const {
  double w = 0;
  for (int i = 0; i < 3; ++i) w += std::sin(2 * kPi * freq_[c][i] * t + phase_[c][i]);
  return amp_[c] * w / std::sqrt(1.5);  // unit RMS before scaling
}

double FlightPath::RoadS(double t, double* heading_offset) const {
  *heading_offset = 0;
  const double v = o_.speed_m_s;
  if (!o_.out_and_back || t <= t_out_) return s_first_ + v * t;
  const double turn = o_.turn_duration_s;
  if (t <= t_out_ + turn) {
    const double u = turn > 0 ? (t - t_out_) / turn : 1.0;
    *heading_offset = kPi * u * u * (3 - 2 * u);
    return s_far_;
  }
  *heading_offset = kPi;
  return s_far_ - v * (t - t_out_ - turn);
}

PlatformState FlightPath::At(double t) const {
  auto pose = [&](double tt, double* s_out) {
    double dh;
    const double s = RoadS(tt, &dh) + Wobble(5, tt);
    const double l = Wobble(0, tt);
    const Eigen::Vector2d xy = road_.ToWorld(s, l);
    const double z = road_.SmoothZ(s, l) + o_.altitude_m + Wobble(1, tt);
    const double h = road_.HeadingRad(s) + dh + Wobble(2, tt);
    Eigen::Matrix3d R_level;  // FRD axes of a level body with ENU heading h
    R_level.col(0) = Eigen::Vector3d(std::cos(h), std::sin(h), 0);
    R_level.col(1) = Eigen::Vector3d(std::sin(h), -std::cos(h), 0);
    R_level.col(2) = Eigen::Vector3d(0, 0, -1);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R_level * Eigen::AngleAxisd(Wobble(3, tt), Eigen::Vector3d::UnitY()).toRotationMatrix() *
                 Eigen::AngleAxisd(Wobble(4, tt), Eigen::Vector3d::UnitX()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(xy.x(), xy.y(), z);
    if (s_out) *s_out = s;
    return T;
  };
  PlatformState st;
  st.T_world_body = pose(t, &st.s_m);
  constexpr double kDt = 1e-3;
  st.v_world = (pose(t + kDt, nullptr).translation() - pose(t - kDt, nullptr).translation()) / (2 * kDt);
  return st;
}

}  // namespace rs::sim
