#include "stages/georeference/georeference.h"

#include <cmath>
#include <stdexcept>

namespace rs {

const char* ToString(RollSource s) {
  switch (s) {
    case RollSource::kAuto: return "auto";
    case RollSource::kAttitude: return "attitude";
    case RollSource::kRoadPlane: return "road_plane";
    case RollSource::kPositions: return "positions";
  }
  return "?";
}

const char* ToString(CameraStatus s) {
  switch (s) {
    case CameraStatus::kVisual: return "visual";
    case CameraStatus::kGnssOnly: return "gnss-only";
    case CameraStatus::kSkipped: return "skipped";
  }
  return "?";
}

Eigen::Matrix3d RotationEnuNed() {
  Eigen::Matrix3d R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return R;
}

Eigen::Vector3d YawPitchRollDeg(const Eigen::Matrix3d& R) {
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const double pitch = -std::asin(std::clamp(R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  return Eigen::Vector3d(yaw, pitch, roll) * 180.0 / M_PI;
}

GeoreferenceResult Georeference(const std::vector<GeoFrame>& frames, const std::vector<Eigen::Vector3d>& map_points,
                                const RigGeometry& rig, const GeoreferenceOptions& o) {
  // Fit samples: placed frames with a fix; the antenna in the SLAM world through the lever arm.
  const Eigen::Vector3d antenna_cam = rig.R_body_cam.transpose() * rig.lever_arm_body_m;
  std::vector<Eigen::Vector3d> a, b;
  std::vector<size_t> sample_frame;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (!frames[i].T_slam_cam || !frames[i].gnss_enu) continue;
    a.push_back(*frames[i].T_slam_cam * antenna_cam);
    b.push_back(*frames[i].gnss_enu);
    sample_frame.push_back(i);
  }
  GeoreferenceResult res;
  res.fit = FitSlamToGnss(a, b, o.fit);

  // Up-directions in the SLAM world for the rotation about the track axis.
  std::vector<Eigen::Vector3d> up_attitude;
  for (size_t k = 0; k < sample_frame.size(); ++k) {
    const GeoFrame& f = frames[sample_frame[k]];
    if (!f.R_ned_body || !res.fit.inlier[k]) continue;
    const Eigen::Matrix3d R_enu_cam = RotationEnuNed() * *f.R_ned_body * rig.R_body_cam;
    up_attitude.push_back(f.T_slam_cam->linear() * (R_enu_cam.transpose() * Eigen::Vector3d::UnitZ()));
  }
  RollSource method = o.roll_source;
  if (method == RollSource::kAuto) method = up_attitude.size() >= 3 ? RollSource::kAttitude : RollSource::kRoadPlane;
  if (method == RollSource::kAttitude && up_attitude.empty())
    throw std::invalid_argument("roll_source attitude: the flight log has no attitude for the fitted frames");
  res.roll_method = method;
  if (method == RollSource::kAttitude) {
    res.roll = RollAboutTrackAxis(up_attitude, a, res.fit);
  } else if (method == RollSource::kRoadPlane) {
    std::vector<Eigen::Vector3d> centres;
    for (const auto& f : frames)
      if (f.T_slam_cam) centres.push_back(f.T_slam_cam->translation());
    std::vector<Eigen::Vector3d> ups;
    for (const auto& plane : FitRoadPlanes(map_points, centres, res.fit.axis_slam, o.road)) ups.push_back(plane.up_slam);
    res.road_planes = static_cast<int>(ups.size());
    if (ups.empty()) res.roll_method = RollSource::kPositions;  // no road found: positions alone
    else res.roll = RollAboutTrackAxis(ups, a, res.fit);
  }

  const Similarity3& S = res.fit.transform;
  for (size_t k = 0; k < sample_frame.size(); ++k) {
    const GeoFrame& f = frames[sample_frame[k]];
    res.residuals.push_back({f.frame, f.t_ns, b[k] - S.Apply(a[k]), res.fit.inlier[k]});
  }
  for (const auto& f : frames) {
    GeoCamera cam;
    cam.frame = f.frame;
    cam.t_ns = f.t_ns;
    if (f.T_slam_cam) {
      cam.status = CameraStatus::kVisual;
      cam.p_enu = S.Apply(f.T_slam_cam->translation());
      const Eigen::Matrix3d R_enu_cam = S.R * f.T_slam_cam->linear();
      cam.R_ned_body = RotationEnuNed() * R_enu_cam * rig.R_body_cam.transpose();
    } else if (f.gnss_enu) {
      // Not placed visually: the fix, moved from the antenna to the camera when the attitude is known.
      cam.status = CameraStatus::kGnssOnly;
      cam.R_ned_body = f.R_ned_body;
      cam.p_enu = *f.gnss_enu;
      if (f.R_ned_body) cam.p_enu -= RotationEnuNed() * *f.R_ned_body * rig.lever_arm_body_m;
    }
    res.cameras.push_back(cam);
  }
  return res;
}

}  // namespace rs
