#pragma once
// `roadsurvey eval georeference OUTPUT TRUTH_DIR`: the georeference stage's cameras.csv against a
// simulated survey's truth (truth/trajectory.tum in the local ENU of truth/georeference.json, the
// mount in truth/scene.json), beside COLMAP's model_aligner on the same SLAM trajectory and GNSS.
// Also measures the GNSS bias the simulator realised (the log's camera events minus truth), which
// no fit to that GNSS can remove.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace GeographicLib {
class LocalCartesian;
}

namespace rs {

/// A camera as an estimate gives it, in the truth's ENU frame.
struct EnuCamera {
  int64_t t_ns = 0;
  Eigen::Vector3d p_enu = Eigen::Vector3d::Zero();
  std::optional<Eigen::Matrix3d> R_ned_body;  ///< body attitude; absent: angles not scored
  int64_t frame = -1;                         ///< cameras.csv's frame id (-1: not read from it)
};

/// cameras.csv rows with status visual, placed in the local ENU frame `enu`. Throws InputError
/// naming the file and line on a malformed row.
std::vector<EnuCamera> ReadOurCameras(const std::filesystem::path& csv, const GeographicLib::LocalCartesian& enu);

/// Camera-centre and attitude errors against truth.
struct CameraErrors {
  int frames = 0;
  double horizontal_rmse_m = 0, vertical_rmse_m = 0, horizontal_max_m = 0, vertical_max_m = 0;
  Eigen::Vector3d mean_error_enu_m = Eigen::Vector3d::Zero();  ///< estimate minus truth, averaged
  int angle_frames = 0;
  /// Mean heading, pitch, roll error, deg: the part a georeference (one rotation) decides; the rest
  /// of the RMS is the trajectory's own frame-to-frame rotation error.
  Eigen::Vector3d mean_angle_error_deg = Eigen::Vector3d::Zero();
  double heading_rms_deg = 0, heading_max_deg = 0, pitch_rms_deg = 0, pitch_max_deg = 0, roll_rms_deg = 0,
         roll_max_deg = 0;
  nlohmann::json ToJson() const;
};

/// Scores `est` against the truth poses (left camera-to-ENU) matched by t_ns; R_body_cam turns
/// the truth's camera rotation into the body attitude the estimate reports.
CameraErrors CompareCameras(const std::vector<EnuCamera>& est, const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& truth,
                            const Eigen::Matrix3d& R_body_cam);

struct GeoreferenceEvaluation {
  CameraErrors ours;
  std::optional<CameraErrors> colmap;  ///< model_aligner on the same input; absent when it could not run
  std::string colmap_note;             ///< how it ran, or why not
  int bias_samples = 0;
  Eigen::Vector3d realised_bias_enu_m = Eigen::Vector3d::Zero();  ///< mean GNSS minus truth at the frames
  nlohmann::json ToJson() const;
  std::string BriefReport() const;
};

/// `output_dir`: the survey's output folder (cameras.csv, trajectory.tum, work/ingest/*/frame_priors.csv);
/// `truth_dir`: the simulator's truth/ folder (its parent holds flight_log.csv). Throws InputError on bad files.
GeoreferenceEvaluation EvaluateGeoreference(const std::filesystem::path& output_dir, const std::filesystem::path& truth_dir,
                                            bool run_colmap);

}  // namespace rs
