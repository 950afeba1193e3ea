#include "eval/georeference/georeference_eval.h"

#include <GeographicLib/LocalCartesian.hpp>
#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <map>

#include "eval/georeference/colmap_aligner.h"
#include "formats/flight_log/flight_log.h"
#include "formats/frame_priors.h"
#include "formats/geo/cameras_csv.h"
#include "formats/input_error.h"
#include "formats/trajectory/tum_trajectory.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr double kRad2Deg = 180.0 / M_PI;

Eigen::Matrix3d EnuNed() {
  Eigen::Matrix3d R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return R;
}

// yaw, pitch, roll (ZYX, body -> NED), radians.
Eigen::Vector3d Ypr(const Eigen::Matrix3d& R) {
  return {std::atan2(R(1, 0), R(0, 0)), -std::asin(std::clamp(R(2, 0), -1.0, 1.0)), std::atan2(R(2, 1), R(2, 2))};
}

nlohmann::json ReadJson(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw InputError(InputLocation::File(p.string()), "cannot open");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(InputLocation::File(p.string()), e.what());
  }
}

Eigen::Matrix3d FromYprDeg(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw / kRad2Deg, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch / kRad2Deg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll / kRad2Deg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace

std::vector<EnuCamera> ReadOurCameras(const fs::path& csv, const GeographicLib::LocalCartesian& enu) {
  std::vector<EnuCamera> out;
  for (const CameraRow& r : ReadCamerasCsv(csv)) {
    if (r.status != "visual" || !r.crs) continue;
    EnuCamera c;
    c.frame = r.frame;
    c.t_ns = r.t_ns;
    enu.Forward(r.lat_deg, r.lon_deg, r.h_ellipsoid_m, c.p_enu.x(), c.p_enu.y(), c.p_enu.z());
    if (r.rpy_deg) c.R_ned_body = FromYprDeg(r.rpy_deg->z(), r.rpy_deg->y(), r.rpy_deg->x());
    out.push_back(c);
  }
  return out;
}

namespace {

// The frame priors ingest wrote (the newest run's, when the cache holds several).
fs::path FindFramePriors(const fs::path& output_dir) {
  fs::path best;
  fs::file_time_type best_time;
  const fs::path ingest = output_dir / "work" / "ingest";
  if (fs::is_directory(ingest))
    for (const auto& e : fs::directory_iterator(ingest)) {
      const fs::path p = e.path() / "frame_priors.csv";
      if (fs::exists(p) && (best.empty() || fs::last_write_time(p) > best_time)) {
        best = p;
        best_time = fs::last_write_time(p);
      }
    }
  if (best.empty()) throw InputError(InputLocation::File(ingest.string()), "no frame_priors.csv in the ingest cache");
  return best;
}

}  // namespace

CameraErrors CompareCameras(const std::vector<EnuCamera>& est,
                            const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& truth,
                            const Eigen::Matrix3d& R_body_cam) {
  std::map<int64_t, Eigen::Isometry3d> by_t(truth.begin(), truth.end());
  CameraErrors e;
  double hh = 0, vv = 0;
  Eigen::Vector3d ss = Eigen::Vector3d::Zero();
  for (const auto& c : est) {
    const auto it = by_t.find(c.t_ns);
    if (it == by_t.end()) continue;
    const Eigen::Vector3d d = c.p_enu - it->second.translation();
    ++e.frames;
    e.mean_error_enu_m += d;
    hh += d.head<2>().squaredNorm();
    vv += d.z() * d.z();
    e.horizontal_max_m = std::max(e.horizontal_max_m, d.head<2>().norm());
    e.vertical_max_m = std::max(e.vertical_max_m, std::abs(d.z()));
    if (!c.R_ned_body) continue;
    const Eigen::Matrix3d R_true = EnuNed() * it->second.linear() * R_body_cam.transpose();
    Eigen::Vector3d a = (Ypr(*c.R_ned_body) - Ypr(R_true)) * kRad2Deg;
    for (int k = 0; k < 3; ++k) a[k] = std::remainder(a[k], 360.0);
    ++e.angle_frames;
    ss += a.cwiseAbs2();
    e.mean_angle_error_deg += a;
    e.heading_max_deg = std::max(e.heading_max_deg, std::abs(a.x()));
    e.pitch_max_deg = std::max(e.pitch_max_deg, std::abs(a.y()));
    e.roll_max_deg = std::max(e.roll_max_deg, std::abs(a.z()));
  }
  if (e.frames == 0) return e;
  e.mean_error_enu_m /= e.frames;
  e.horizontal_rmse_m = std::sqrt(hh / e.frames);
  e.vertical_rmse_m = std::sqrt(vv / e.frames);
  if (e.angle_frames > 0) {
    const Eigen::Vector3d rms = (ss / e.angle_frames).cwiseSqrt();
    e.mean_angle_error_deg /= e.angle_frames;
    e.heading_rms_deg = rms.x();
    e.pitch_rms_deg = rms.y();
    e.roll_rms_deg = rms.z();
  }
  return e;
}

nlohmann::json CameraErrors::ToJson() const {
  return {{"frames", frames},
          {"horizontal_rmse_m", horizontal_rmse_m},
          {"vertical_rmse_m", vertical_rmse_m},
          {"horizontal_max_m", horizontal_max_m},
          {"vertical_max_m", vertical_max_m},
          {"mean_error_enu_m", {mean_error_enu_m.x(), mean_error_enu_m.y(), mean_error_enu_m.z()}},
          {"angle_frames", angle_frames},
          {"heading_deg", {{"rms", heading_rms_deg}, {"max", heading_max_deg}}},
          {"pitch_deg", {{"rms", pitch_rms_deg}, {"max", pitch_max_deg}}},
          {"roll_deg", {{"rms", roll_rms_deg}, {"max", roll_max_deg}}},
          {"mean_angle_error_deg",
           {{"heading", mean_angle_error_deg.x()},
            {"pitch", mean_angle_error_deg.y()},
            {"roll", mean_angle_error_deg.z()}}}};
}

nlohmann::json GeoreferenceEvaluation::ToJson() const {
  nlohmann::json j = {
      {"ours", ours.ToJson()},
      {"colmap_model_aligner", colmap ? colmap->ToJson() : nlohmann::json()},
      {"colmap_note", colmap_note},
      {"realised_gnss_bias_enu_m", {realised_bias_enu_m.x(), realised_bias_enu_m.y(), realised_bias_enu_m.z()}},
      {"realised_gnss_bias_horizontal_m", realised_bias_enu_m.head<2>().norm()},
      {"bias_samples", bias_samples}};
  // What a fit to biased GNSS can reach: our mean error should be the bias.
  j["ours_mean_error_minus_bias_horizontal_m"] = (ours.mean_error_enu_m - realised_bias_enu_m).head<2>().norm();
  return j;
}

std::string GeoreferenceEvaluation::BriefReport() const {
  auto line = [](const char* who, const CameraErrors& e) {
    return fmt::format(
        "{:<22} {:>3} frames  centre RMSE h {:.3f} m v {:.3f} m (max {:.3f} / {:.3f})  heading {:.3f}/{:.3f} deg  "
        "pitch {:.3f}/{:.3f}  roll {:.3f}/{:.3f} (RMS/max); mean h/p/r {:+.3f} {:+.3f} {:+.3f} deg\n",
        who, e.frames, e.horizontal_rmse_m, e.vertical_rmse_m, e.horizontal_max_m, e.vertical_max_m, e.heading_rms_deg,
        e.heading_max_deg, e.pitch_rms_deg, e.pitch_max_deg, e.roll_rms_deg, e.roll_max_deg, e.mean_angle_error_deg.x(),
        e.mean_angle_error_deg.y(), e.mean_angle_error_deg.z());
  };
  std::string s = line("georeference", ours);
  s += colmap ? line("colmap model_aligner", *colmap) : "colmap model_aligner: " + colmap_note + "\n";
  s += fmt::format(
      "realised GNSS bias (log's camera events minus truth, {} frames): E {:+.3f} N {:+.3f} U {:+.3f} m "
      "(horizontal {:.3f} m); our mean error minus bias, horizontal: {:.3f} m\n",
      bias_samples, realised_bias_enu_m.x(), realised_bias_enu_m.y(), realised_bias_enu_m.z(),
      realised_bias_enu_m.head<2>().norm(), (ours.mean_error_enu_m - realised_bias_enu_m).head<2>().norm());
  return s;
}

GeoreferenceEvaluation EvaluateGeoreference(const fs::path& output_dir, const fs::path& truth_dir, bool run_colmap) {
  const auto origin = ReadJson(truth_dir / "georeference.json").at("origin");
  const GeographicLib::LocalCartesian enu(origin.at("lat_deg").get<double>(), origin.at("lon_deg").get<double>(),
                                          origin.at("h_ellipsoid_m").get<double>());
  const auto R_rows = ReadJson(truth_dir / "scene.json").at("T_body_cam").at("R_row_major").get<std::vector<double>>();
  Eigen::Matrix3d R_body_cam;
  for (int i = 0; i < 9; ++i) R_body_cam(i / 3, i % 3) = R_rows.at(i);
  std::vector<std::pair<int64_t, Eigen::Isometry3d>> truth;
  for (const auto& p : ReadTumTrajectory(truth_dir / "trajectory.tum").poses)
    truth.emplace_back(p.t_ns, p.T_world_frame);

  GeoreferenceEvaluation ev;
  ev.ours = CompareCameras(ReadOurCameras(output_dir / "cameras.csv", enu), truth, R_body_cam);

  // The realised bias: the simulator logs camera events at the true exposure with truth + bias.
  std::map<int64_t, Eigen::Isometry3d> truth_by_t(truth.begin(), truth.end());
  const fs::path log = truth_dir.parent_path() / "flight_log.csv";
  if (fs::exists(log)) {
    for (const auto& ev_cam : ReadFlightLog(log).camera_events) {
      const auto it = truth_by_t.find(ev_cam.t_ns);
      if (it == truth_by_t.end()) continue;
      Eigen::Vector3d p;
      enu.Forward(ev_cam.lat_deg, ev_cam.lon_deg, ev_cam.alt_m, p.x(), p.y(), p.z());
      ev.realised_bias_enu_m += p - it->second.translation();
      ++ev.bias_samples;
    }
    if (ev.bias_samples > 0) ev.realised_bias_enu_m /= ev.bias_samples;
  }

  if (!run_colmap) {
    ev.colmap_note = "not run";
    return ev;
  }
  // model_aligner on the same inputs: the published SLAM trajectory and the frames' GNSS priors.
  std::vector<std::pair<int64_t, Eigen::Isometry3d>> slam;
  for (const auto& p : ReadTumTrajectory(output_dir / "trajectory.tum").poses)
    slam.emplace_back(p.t_ns, p.T_world_frame);
  std::map<int64_t, Eigen::Vector3d> refs;
  double sigma = 0;
  int n_sigma = 0;
  for (const auto& pr : ReadFramePriors(FindFramePriors(output_dir))) {
    if (pr.status != PriorStatus::kOk) continue;
    Eigen::Vector3d p;
    enu.Forward(pr.lat_deg, pr.lon_deg, pr.alt_m, p.x(), p.y(), p.z());
    refs[pr.t_ns] = p;
    if (!std::isnan(pr.h_acc_m)) sigma += pr.h_acc_m, ++n_sigma;
  }
  const double gate = 3.0 * (n_sigma > 0 ? sigma / n_sigma : 2.0);  // the same 3-sigma gate as ours
  const auto aligned = AlignWithColmap(slam, refs, gate, output_dir / "eval_colmap_aligner", &ev.colmap_note);
  if (aligned) {
    std::vector<EnuCamera> cams;
    for (const auto& [t_ns, T] : *aligned)
      cams.push_back({t_ns, T.translation(), Eigen::Matrix3d(EnuNed() * T.linear() * R_body_cam.transpose())});
    ev.colmap = CompareCameras(cams, truth, R_body_cam);
  }
  return ev;
}

}  // namespace rs
