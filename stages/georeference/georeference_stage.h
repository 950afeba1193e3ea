#pragma once
// Stage "georeference": every camera of the trajectory in the survey's CRS. Fits the SLAM
// trajectory to the flight log's GNSS antenna positions (robust SE(3), or Sim(3)), fixes the roll
// about the track axis from the log's attitude or the road plane, and publishes
// georeference.json, cameras.csv, trajectory.geojson and georeference_residuals.png.
// Docs: docs/stages/georeference.md.

#include <string>

#include "stages/georeference/georeference.h"
#include "survey/stage.h"

namespace rs {

/// The artifacts this stage aligns: a trajectory (every placed frame, left camera-to-world) and a
/// map in the same world frame, each named by its artifact and the file or folder inside it.
struct AlignedInputs {
  const char* trajectory_artifact;
  const char* trajectory_file;
  const char* map_artifact;
  const char* map_dir;
};
inline constexpr AlignedInputs kSlamOutputs{"trajectory", "trajectory.tum", "map", "map"};
inline constexpr AlignedInputs kRefinedOutputs{"trajectory_refined", "trajectory_refined.tum", "refined_map", "map"};
/// What the stage reads: the refine stage's outputs (slam's when refine is disabled: a copy).
inline constexpr AlignedInputs kGeoreferenceInputs = kRefinedOutputs;

struct GeoreferenceStageOptions {
  bool estimate_scale = false;      ///< Sim(3) instead of SE(3) at the stereo rig's metric scale
  double lever_arm_x_m = 0;         ///< antenna minus left camera, body forward, m
  double lever_arm_y_m = 0;         ///< antenna minus left camera, body right, m
  double lever_arm_z_m = 0;         ///< antenna minus left camera, body down, m
  /// Camera axes (OpenCV: x right, y down, z forward) in the body FRD frame: R_body_cam, 9 numbers
  /// row by row. Default: a forward-looking camera (x = right, y = down, z = forward).
  std::string camera_axes_in_body = "0,0,1, 1,0,0, 0,1,0";
  double default_gnss_sigma_m = 2.0;  ///< GNSS sigma when the log gives no accuracy, m
  double outlier_sigmas = 3.0;        ///< a fix this many sigmas off on any axis is an outlier
  double huber_k = 1.345;             ///< Huber threshold, robust sigmas
  int ransac_iterations = 200;        ///< 3-point hypotheses
  int64_t seed = 1;                   ///< RANSAC seed
  RollSource roll_source = RollSource::kAuto;  ///< where the roll about the track axis comes from
  double road_window_m = 10;          ///< track length per road plane, m
  double road_tolerance_m = 0.10;     ///< road plane inlier distance, m
  double road_range_m = 20;           ///< map points within this distance of the cameras, m
  std::string heights = "ellipsoid";  ///< output heights: "ellipsoid" (WGS84) or "geoid" (EGM96)
  std::string enu_origin;             ///< "lat,lon,h_ellipsoid" of the enu CRS origin; empty: GNSS centre

  void Check() const;
  static const OptionTable<GeoreferenceStageOptions>& Table();
  /// Parsed camera_axes_in_body (orthonormal, det +1: Check() ensures it).
  Eigen::Matrix3d RBodyCam() const;
};

class GeoreferenceStage : public TypedStage<GeoreferenceStage, GeoreferenceStageOptions> {
 public:
  static StageInfo Info();
  void Run(StageContext& ctx, const GeoreferenceStageOptions& options) const;
  void ValidateInputs(const SurveyFile& survey, const GeoreferenceStageOptions& options, ValidationDepth depth,
                      ProblemList& problems) const;
};

}  // namespace rs
