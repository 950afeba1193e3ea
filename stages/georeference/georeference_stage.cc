#include "stages/georeference/georeference_stage.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "formats/checked_file.h"
#include "formats/frame_priors.h"
#include "formats/geojson/geojson.h"
#include "formats/geo/output_crs.h"
#include "formats/slam_map/slam_map_file.h"
#include "formats/trajectory/tum_trajectory.h"
#include "stages/georeference/georeference_outputs.h"
#include "stages/georeference/residual_plot.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr const char* kStage = "georeference";

// Splits "a, b, c" into numbers; nullopt when a field is not a finite number.
std::optional<std::vector<double>> ParseNumbers(const std::string& text) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string field;
  while (std::getline(ss, field, ',')) {
    try {
      size_t used = 0;
      out.push_back(std::stod(field, &used));
      if (field.find_first_not_of(" \t", used) != std::string::npos || !std::isfinite(out.back())) return std::nullopt;
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
  return out;
}

HeightReference Heights(const GeoreferenceStageOptions& o) {
  return o.heights == "geoid" ? HeightReference::kGeoidEgm96 : HeightReference::kEllipsoid;
}

// The prior's height as WGS84 ellipsoidal; false (with the height unchanged) when the log's
// datum is unknown or take-off relative.
bool EllipsoidalHeight(const FramePrior& p, double* h) {
  *h = std::isnan(p.alt_m) ? 0.0 : p.alt_m;
  if (p.alt_ref == AltitudeReference::kEllipsoid) return true;
  if (p.alt_ref == AltitudeReference::kAmsl) {
    *h += Egm96UndulationM(p.lat_deg, p.lon_deg);
    return true;
  }
  return false;
}

Eigen::Matrix3d RotationFromPrior(const FramePrior& p) {
  return Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz).normalized().toRotationMatrix();
}

// ingest.json's clock-offset report (the priors are already interpolated with it), or null.
nlohmann::json ClockOffsetReport(const fs::path& ingest_dir) {
  std::ifstream in(ingest_dir / "ingest.json");
  if (!in) return nullptr;
  const auto j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || !j.contains("flight_log") || !j["flight_log"].is_object()) return nullptr;
  return j["flight_log"].value("clock_offset", nlohmann::json());
}

// One GeoFrame per selected frame of the priors (every frame ingest listed), its pose found by t_ns,
// its fix in the fit's ENU frame; collects the logged accuracies and counts frames with attitude.
std::vector<GeoFrame> MakeGeoFrames(const std::vector<FramePrior>& priors, const Trajectory& trajectory,
                                    const FrameSelection& selection, const GeographicLib::LocalCartesian& enu,
                                    std::vector<double>* h_acc, int* with_attitude) {
  std::map<int64_t, Eigen::Isometry3d> pose_by_t;
  for (const auto& sp : trajectory.poses) pose_by_t.emplace(sp.t_ns, sp.T_world_frame);
  std::vector<GeoFrame> frames;
  for (const auto& p : priors) {
    if (!selection.Contains(p.id.value)) continue;
    GeoFrame f;
    f.frame = p.id.value;
    f.t_ns = p.t_ns;
    if (const auto it = pose_by_t.find(p.t_ns); it != pose_by_t.end()) f.T_slam_cam = it->second;
    if (p.status == PriorStatus::kOk) {
      double h;
      EllipsoidalHeight(p, &h);
      Eigen::Vector3d x;
      enu.Forward(p.lat_deg, p.lon_deg, h, x.x(), x.y(), x.z());
      f.gnss_enu = x;
      if (!std::isnan(p.h_acc_m)) h_acc->push_back(p.h_acc_m);
      if (p.has_attitude) {
        f.R_ned_body = RotationFromPrior(p);
        ++*with_attitude;
      }
    }
    frames.push_back(f);
  }
  return frames;
}

// The algorithm's options; the GNSS sigma is the median logged accuracy, else the option's default.
GeoreferenceOptions AlgorithmOptions(const GeoreferenceStageOptions& o, std::vector<double> h_acc) {
  GeoreferenceOptions go;
  go.fit.estimate_scale = o.estimate_scale;
  go.fit.outlier_sigmas = o.outlier_sigmas;
  go.fit.huber_k = o.huber_k;
  go.fit.ransac_iterations = o.ransac_iterations;
  go.fit.seed = static_cast<uint64_t>(o.seed);
  if (h_acc.empty()) {
    go.fit.sigma_m = o.default_gnss_sigma_m;
  } else {
    std::nth_element(h_acc.begin(), h_acc.begin() + static_cast<std::ptrdiff_t>(h_acc.size() / 2), h_acc.end());
    go.fit.sigma_m = std::max(h_acc[h_acc.size() / 2], 0.005);  // RTK logs can claim millimetres
  }
  go.roll_source = o.roll_source;
  go.road.window_m = o.road_window_m;
  go.road.tolerance_m = o.road_tolerance_m;
  go.road.max_range_m = o.road_range_m;
  go.road.seed = static_cast<uint64_t>(o.seed);
  return go;
}

// Outputs of a survey that cannot be georeferenced: every frame skipped, an empty GeoJSON, the reason.
void PublishNotGeoreferenced(StageContext& ctx, const std::vector<FramePrior>& priors, const std::string& why) {
  std::ostringstream csv;
  csv << "frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,yaw_deg,status\n";
  int64_t frames = 0;
  for (const auto& p : priors)
    if (ctx.frame_selection().Contains(p.id.value)) {
      csv << p.id.value << ',' << p.t_ns << ",,,,,,,,,,skipped\n";  // 12 fields, as the header
      ++frames;
    }
  WriteFileChecked(ctx.out_dir() / "cameras.csv", csv.view());
  std::ostringstream geo;
  geojson::WriteFeatureCollection(geo, geojson::FeatureCollection{});
  WriteFileChecked(ctx.out_dir() / "trajectory.geojson", geo.view());
  WriteGnssResidualCsv(ctx.out_dir() / "georeference_residuals.csv", {});
  WriteGnssResidualPlot(ctx.out_dir() / "georeference_residuals.png", {}, Eigen::Vector3d::Zero(),
                        "not georeferenced: " + why);
  WriteJsonAtomic(ctx.out_dir() / "georeference.json",
                  {{"format", "roadsurvey-georeference-v1"}, {"georeferenced", false}, {"reason", why},
                   {"frames", {{"visual", 0}, {"gnss-only", 0}, {"skipped", frames}}}});
  ctx.summary().frames_total = frames;
  ctx.summary().frames_computed = frames;
  ctx.Count("frames_skipped", static_cast<double>(frames));
  ctx.Warn("not georeferenced: " + why);
}

}  // namespace

Eigen::Matrix3d GeoreferenceStageOptions::RBodyCam() const {
  const auto v = ParseNumbers(camera_axes_in_body);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (v && v->size() == 9)
    for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = (*v)[i];
  return R;
}

void GeoreferenceStageOptions::Check() const {
  const auto v = ParseNumbers(camera_axes_in_body);
  CheckRule(v && v->size() == 9, kStage, "camera_axes_in_body", camera_axes_in_body, "9 comma-separated numbers");
  const Eigen::Matrix3d R = RBodyCam();
  CheckRule((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-4 && R.determinant() > 0, kStage,
            "camera_axes_in_body", camera_axes_in_body, "a rotation (orthonormal rows, determinant +1, to 1e-4)");
  if (!enu_origin.empty()) {
    const auto o = ParseNumbers(enu_origin);
    CheckRule(o && o->size() == 3 && std::abs((*o)[0]) <= 90 && std::abs((*o)[1]) <= 180, kStage, "enu_origin",
              enu_origin, "\"lat_deg,lon_deg,h_ellipsoid_m\" with |lat| <= 90 and |lon| <= 180");
  }
}

const OptionTable<GeoreferenceStageOptions>& GeoreferenceStageOptions::Table() {
  using O = GeoreferenceStageOptions;
  static const auto t =
      OptionTable<O>()
          .Add("estimate_scale", &O::estimate_scale,
               "fit Sim(3) (scale estimated and reported with its sigma) instead of SE(3) at the stereo metric scale")
          .Add("lever_arm_x_m", &O::lever_arm_x_m, "GNSS antenna minus left camera centre, body forward", "m")
          .Add("lever_arm_y_m", &O::lever_arm_y_m, "GNSS antenna minus left camera centre, body right", "m")
          .Add("lever_arm_z_m", &O::lever_arm_z_m, "GNSS antenna minus left camera centre, body down", "m")
          .Add("camera_axes_in_body", &O::camera_axes_in_body,
               "camera mount: the left camera's axes (x right, y down, z forward) in the body FRD frame, the "
               "rotation R_body_cam row by row (9 numbers); default a forward-looking camera")
          .Add("default_gnss_sigma_m", &O::default_gnss_sigma_m,
               "GNSS position sigma when the flight log gives no accuracy (RANSAC gate = outlier_sigmas x sigma)", "m")
          .Above(0)
          .Add("outlier_sigmas", &O::outlier_sigmas, "a fix this many robust sigmas off on any axis is an outlier")
          .Above(1)
          .Add("huber_k", &O::huber_k, "Huber threshold of the reweighted fit, in robust sigmas")
          .Above(0)
          .Add("ransac_iterations", &O::ransac_iterations, "3-point RANSAC hypotheses")
          .Min(1)
          .Add("seed", &O::seed, "RANSAC seed (same input and seed, same result)")
          .AddEnum("roll_source", &O::roll_source,
                   {{"auto", RollSource::kAuto},
                    {"attitude", RollSource::kAttitude},
                    {"road_plane", RollSource::kRoadPlane},
                    {"positions", RollSource::kPositions}},
                   "rotation about the track axis (unobservable from positions on a straight road): the flight "
                   "log's gravity direction, the road plane under the cameras, or positions alone; auto = attitude "
                   "when the log has it, else road plane")
          .Add("road_window_m", &O::road_window_m, "track length whose map points make one road plane", "m")
          .Above(0)
          .Add("road_tolerance_m", &O::road_tolerance_m,
               "road plane inlier distance: above the camber's rise across a lane (2.5 % x 3.5 m = 9 cm)", "m")
          .Above(0)
          .Add("road_range_m", &O::road_range_m, "map points within this distance of the window's cameras", "m")
          .Above(0)
          .Add("heights", &O::heights,
               "output heights: ellipsoid (WGS84 ellipsoidal) or geoid (above EGM96, EPSG:5773, PROJ grid)")
          .OneOf({"ellipsoid", "geoid"})
          .Add("enu_origin", &O::enu_origin,
               "origin of the crs \"enu\" as \"lat_deg,lon_deg,h_ellipsoid_m\"; empty: the centre of the GNSS fixes");
  return t;
}

StageInfo GeoreferenceStage::Info() {
  StageInfo info;
  info.name = kStage;
  info.version = 2;  // 2: georeference_residuals.csv
  info.doc =
      "Every camera in the survey's CRS: robust SE(3)/Sim(3) fit of the trajectory to the flight log's GNSS "
      "antenna positions, roll about the track axis from the log's attitude or the road plane, residuals per "
      "axis; publishes georeference.json, cameras.csv, trajectory.geojson, georeference_residuals.png.";
  info.inputs = {kGeoreferenceInputs.trajectory_artifact, kGeoreferenceInputs.map_artifact, "priors"};
  info.outputs = {"georeference"};
  info.published = {{"georeference.json", "georeference.json"},
                    {"cameras.csv", "cameras.csv"},
                    {"trajectory.geojson", "trajectory.geojson"},
                    {"georeference_residuals.png", "georeference_residuals.png"},
                    {"georeference_residuals.csv", "georeference_residuals.csv"}};
  info.per_frame = true;  // its result depends on the frame selection
  return info;
}

// The survey's crs is checked before anything runs (`validate`, and `run` up front): a code PROJ does
// not know, or geoid heights on a local tangent plane, would otherwise fail only after SLAM.
void GeoreferenceStage::ValidateInputs(const SurveyFile& survey, const GeoreferenceStageOptions& o, ValidationDepth,
                                       ProblemList& problems) const {
  try {
    // Any centre serves: it only picks the UTM zone or the tangent plane's origin.
    OutputCrs(survey.crs, Geodetic{}, Heights(o));
  } catch (const std::exception& e) {
    problems.Error(InputLocation::File(survey.path.string()), e.what());
  }
}

void GeoreferenceStage::Run(StageContext& ctx, const GeoreferenceStageOptions& o) const {
  const auto t_start = std::chrono::steady_clock::now();
  const fs::path traj_path =
      ctx.input_dir(kGeoreferenceInputs.trajectory_artifact) / kGeoreferenceInputs.trajectory_file;
  const Trajectory trajectory = ReadTumTrajectory(traj_path);
  std::vector<Eigen::Vector3d> map_points;  // the road plane needs positions only
  for (const auto& p : ReadSlamMap(ctx.input_dir(kGeoreferenceInputs.map_artifact) / kGeoreferenceInputs.map_dir).points)
    map_points.push_back(p.p_world);
  const fs::path priors_path = ctx.input_dir("priors") / "frame_priors.csv";
  const auto priors = ReadFramePriors(priors_path);

  // The fit's ENU frame: tangent at the centre of the selected frames' fixes.
  std::vector<const FramePrior*> fixes;
  Geodetic centre{0, 0, 0};
  bool heights_ellipsoidal = true;
  for (const auto& p : priors) {
    if (!ctx.frame_selection().Contains(p.id.value) || p.status != PriorStatus::kOk) continue;
    double h;
    heights_ellipsoidal &= EllipsoidalHeight(p, &h);
    fixes.push_back(&p);
    centre.lat_deg += p.lat_deg;
    centre.lon_deg += p.lon_deg;
    centre.h_ellipsoid_m += h;
  }
  if (fixes.size() < 3) {
    // A survey without a flight log still runs: the outputs say that nothing is georeferenced.
    const std::string why = fmt::format("{} selected frame(s) with a GNSS fix in {}; georeferencing needs at least 3",
                                        fixes.size(), priors_path.filename().string());
    PublishNotGeoreferenced(ctx, priors, why);
    return;
  }
  centre.lat_deg /= fixes.size();
  centre.lon_deg /= fixes.size();
  centre.h_ellipsoid_m /= fixes.size();
  if (!heights_ellipsoidal)
    ctx.Warn("the flight log's altitudes are take-off relative or of unknown datum: output heights are on that "
             "datum, not the WGS84 ellipsoid");
  GeoFrames g{GeographicLib::LocalCartesian(centre.lat_deg, centre.lon_deg, centre.h_ellipsoid_m), centre, nullptr};

  // The output CRS before the fit: a CRS PROJ does not know fails before any work.
  Geodetic crs_origin = centre;
  if (!o.enu_origin.empty()) {
    const auto v = *ParseNumbers(o.enu_origin);
    crs_origin = {v[0], v[1], v[2]};
  }
  std::unique_ptr<OutputCrs> crs;
  try {
    crs = std::make_unique<OutputCrs>(ctx.survey().crs, crs_origin, Heights(o));
  } catch (const std::exception& e) {
    throw OptionError(fmt::format("survey crs: {}", e.what()));
  }
  g.crs = crs.get();

  std::vector<double> h_acc;
  int with_attitude = 0;
  const std::vector<GeoFrame> frames = MakeGeoFrames(priors, trajectory, ctx.frame_selection(), g.enu, &h_acc, &with_attitude);

  const GeoreferenceOptions go = AlgorithmOptions(o, h_acc);
  RigGeometry rig;
  rig.lever_arm_body_m = Eigen::Vector3d(o.lever_arm_x_m, o.lever_arm_y_m, o.lever_arm_z_m);
  rig.R_body_cam = o.RBodyCam();

  GeoreferenceResult result;
  try {
    result = Georeference(frames, map_points, rig, go);
  } catch (const std::invalid_argument& e) {
    throw InputError(InputLocation::File(traj_path.string()), e.what());
  }

  WriteCamerasCsv(ctx.out_dir() / "cameras.csv", result, g);
  WriteTrajectoryGeoJson(ctx.out_dir() / "trajectory.geojson", result, g);
  nlohmann::json report = GeoreferenceReport(result, g, o.estimate_scale);
  if (crs->is_local_enu())
    report["crs"]["enu_origin"] = {{"lat_deg", crs_origin.lat_deg}, {"lon_deg", crs_origin.lon_deg},
                                   {"h_ellipsoid_m", crs_origin.h_ellipsoid_m}};
  report["gnss"] = {{"sigma_used_m", go.fit.sigma_m},
                    {"heights", heights_ellipsoidal ? "WGS84 ellipsoidal (AMSL converted through EGM96)"
                                                    : "as logged (take-off relative or unknown datum)"},
                    {"frames_with_attitude", with_attitude},
                    {"clock_offset", ClockOffsetReport(ctx.input_dir("priors"))}};
  report["rig"] = {{"lever_arm_body_m", {o.lever_arm_x_m, o.lever_arm_y_m, o.lever_arm_z_m}},
                   {"camera_axes_in_body", o.camera_axes_in_body}};
  report["inputs"] = {{"trajectory", kGeoreferenceInputs.trajectory_artifact}, {"map", kGeoreferenceInputs.map_artifact},
                      {"map_points", map_points.size()}};

  std::map<CameraStatus, int> by_status;
  for (const auto& c : result.cameras) ++by_status[c.status];
  int outliers = 0;
  for (const auto& r : result.residuals) outliers += !r.inlier;
  WriteGnssResidualCsv(ctx.out_dir() / "georeference_residuals.csv", result.residuals);
  WriteGnssResidualPlot(ctx.out_dir() / "georeference_residuals.png", result.residuals, result.fit.sigma_axis_m,
                        fmt::format("georeference: {} fixes, {} outliers, roll from {}", result.residuals.size(),
                                    outliers, ToString(result.roll_method)));
  report["georeferenced"] = true;
  report["frames"] = {{"visual", by_status[CameraStatus::kVisual]},
                      {"gnss-only", by_status[CameraStatus::kGnssOnly]},
                      {"skipped", by_status[CameraStatus::kSkipped]}};
  WriteJsonAtomic(ctx.out_dir() / "georeference.json", report);

  ctx.summary().frames_total = static_cast<int64_t>(frames.size());
  ctx.summary().frames_computed = static_cast<int64_t>(frames.size());
  ctx.Count("frames_visual", by_status[CameraStatus::kVisual]);
  ctx.Count("frames_gnss_only", by_status[CameraStatus::kGnssOnly]);
  ctx.Count("frames_skipped", by_status[CameraStatus::kSkipped]);
  ctx.Count("gnss_fixes_fitted", static_cast<double>(result.residuals.size()));
  ctx.Count("gnss_outliers", outliers);
  ctx.Count("residual_rms_horizontal_m", report["residuals"]["inliers"]["rmse_m"]["horizontal"].get<double>());
  ctx.summary().counts["roll_method"] = ToString(result.roll_method);
  if (o.estimate_scale) ctx.Count("scale", result.fit.transform.scale);
  if (by_status[CameraStatus::kSkipped] > 0)
    ctx.Warn(fmt::format("{} frame(s) neither placed by the trajectory nor with a GNSS fix: status skipped in cameras.csv",
                         by_status[CameraStatus::kSkipped]));
  if (result.roll_method == RollSource::kPositions && o.roll_source != RollSource::kPositions)
    ctx.Warn("no road plane found: the roll about the track axis rests on positions alone");
  ctx.Time("georeference", std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count());
}

}  // namespace rs
