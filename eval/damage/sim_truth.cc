#include "eval/damage/sim_truth.h"

#include "formats/geojson/geojson.h"
#include "formats/input_error.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/trajectory/tum_trajectory.h"
#include "survey/atomic_file.h"

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>

namespace rs {
namespace fs = std::filesystem;
namespace {

cv::Mat ReadPng(const fs::path& path, int type) {
  const cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (m.empty() || m.type() != type)
    throw InputError(InputLocation::File(path.string()),
                     type == CV_16UC1 ? "expected a 16-bit grey PNG" : "expected an 8-bit grey image");
  return m;
}

// The simulation's options (scene.json "options"): the intact road's geometry.
SimulationOptions ReadSceneOptions(const fs::path& path, const nlohmann::json& j) {
  if (!j.contains("options") || !j["options"].is_object())
    throw InputError(InputLocation::File(path.string()), "no simulation options");
  try {
    const auto& table = SimulationOptions::Table();
    return table.FromJson(table.Merge(j["options"], "simulate"));
  } catch (const std::exception& e) {
    throw InputError(InputLocation::File(path.string()), e.what());
  }
}

}  // namespace

SimSurveyTruth ReadSimSurveyTruth(const fs::path& dir) {
  SimSurveyTruth s;
  s.dir = dir;
  const StereoCalibration calib = ReadCalibrationYaml(dir / "calibration.yaml");
  s.geometry = RectifiedStereoOf(calib);
  s.trajectory = ReadTumTrajectory(dir / "truth/trajectory.tum");
  s.scene = ReadJsonFile(dir / "truth/scene.json");
  s.options = ReadSceneOptions(dir / "truth/scene.json", s.scene);
  for (const auto& e : fs::directory_iterator(dir / "left"))
    if (e.path().extension() == ".png") s.frames.push_back(e.path().stem().string());
  std::sort(s.frames.begin(), s.frames.end());
  if (s.frames.size() != s.trajectory.poses.size())
    throw InputError(InputLocation::File((dir / "truth/trajectory.tum").string()),
                     fmt::format("{} poses for {} frames", s.trajectory.poses.size(), s.frames.size()));
  return s;
}

SimFrameTruth ReadSimFrame(const SimSurveyTruth& s, size_t k) {
  const std::string& name = s.frames.at(k);
  SimFrameTruth f;
  f.left = ReadPng(s.dir / "left" / (name + ".png"), CV_8UC1);
  f.masks = ReadPng(s.dir / "truth/masks" / (name + ".png"), CV_16UC1);
  ReadPng(s.dir / "truth/disparity" / (name + ".png"), CV_16UC1).convertTo(f.truth_disparity_px, CV_32F, 1.0 / 256.0);
  return f;
}

cv::Mat ReadSimRightImage(const SimSurveyTruth& s, size_t k) {
  return ReadPng(s.dir / "right" / (s.frames.at(k) + ".png"), CV_8UC1);
}

TruthFeatureKey ReadTruthFeatureKey(const nlohmann::json& p, const std::filesystem::path& path) {
  if (!p.is_object() || !p.contains("id") || !p["id"].is_number_integer() || !p.contains("type") ||
      !p["type"].is_string())
    throw InputError(InputLocation::File(path.string()), "damage feature without integer id and type");
  return {p["id"].get<int>(), p["type"].get<std::string>()};
}

std::map<int, TruthDamage> ReadTruthDamages(const std::filesystem::path& path) {
  const auto num = [](const nlohmann::json& p, const char* key) {
    return p.contains(key) && p[key].is_number() ? p[key].get<double>() : 0.0;
  };
  std::map<int, TruthDamage> out;
  for (const auto& f : geojson::ReadFeatureCollection(path).features) {
    const auto& p = f.properties;
    const TruthFeatureKey key = ReadTruthFeatureKey(p, path);
    TruthDamage d;
    d.type = key.type;
    d.area_m2 = num(p, "area_m2"), d.max_depth_m = num(p, "max_depth_m"), d.volume_m3 = num(p, "volume_m3");
    d.mean_diameter_m = num(p, "mean_diameter_m");
    d.severity = p.contains("severity") && p["severity"].is_string() ? p["severity"].get<std::string>() : "";
    out[key.id] = d;
  }
  return out;
}

}  // namespace rs
