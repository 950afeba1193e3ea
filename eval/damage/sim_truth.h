#pragma once
// Reading a `roadsurvey simulate` folder for the evaluators (sim_damage_eval, sim_crack_eval):
// the stereo geometry, the true poses, the scene, and each frame's images and truth rasters,
// with file-named errors on bad input.

#include "formats/trajectory/trajectory.h"
#include "stages/damage/damage_types.h"
#include "sim/simulation_options.h"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace rs {

/// A simulated survey's truth that holds for every frame.
struct SimSurveyTruth {
  std::filesystem::path dir;
  RectifiedStereo geometry;         ///< from calibration.yaml (rectified pair)
  Trajectory trajectory;            ///< truth/trajectory.tum: one pose per frame
  nlohmann::json scene;             ///< truth/scene.json
  SimulationOptions options;        ///< the scene's "options": the intact road's geometry
  std::vector<std::string> frames;  ///< stems of left/*.png, sorted; frames[k] has trajectory pose k
};

/// One frame: the left image, the truth instance masks (16-bit ids) and the truth disparity (px).
struct SimFrameTruth {
  cv::Mat left, masks, truth_disparity_px;
};

/// Throws InputError naming the file on a missing or malformed one, or when the frame count and
/// the pose count differ.
SimSurveyTruth ReadSimSurveyTruth(const std::filesystem::path& dir);
SimFrameTruth ReadSimFrame(const SimSurveyTruth& survey, size_t k);
cv::Mat ReadSimRightImage(const SimSurveyTruth& survey, size_t k);

/// A truth/damages.geojson feature's integer "id" and string "type" (both evaluators key on them);
/// throws InputError naming `path` when either is missing.
struct TruthFeatureKey {
  int id = 0;
  std::string type;
};
TruthFeatureKey ReadTruthFeatureKey(const nlohmann::json& properties, const std::filesystem::path& path);

/// One damage of truth/damages.geojson: its type and the measurements the evaluators score
/// (0 where the feature has none).
struct TruthDamage {
  std::string type;
  double area_m2 = 0, max_depth_m = 0, volume_m3 = 0, mean_diameter_m = 0;
  std::string severity;
};

/// Every damage of a truth/damages.geojson by id; throws InputError naming `path` on a feature
/// without integer id and type.
std::map<int, TruthDamage> ReadTruthDamages(const std::filesystem::path& path);

}  // namespace rs
