#include "survey/survey_schema.h"

#include <iterator>

#include "survey/stage.h"

namespace rs {

const char* const kFrameLayouts[] = {"auto", "plain", "kitti-odometry", "kitti-raw", "euroc"};
const char* const kFlightLogFormats[] = {
    "auto", "csv", "airdata-csv", "gpx", "px4-ulog", "ardupilot-dataflash", "dji-srt", "kitti-oxts"};

namespace {

nlohmann::json PathInput(const std::string& description) {
  return {
      {"type", "object"},
      {"description", description},
      {"additionalProperties", false},
      {"required", {"path"}},
      {"properties",
       {{"path", {{"type", "string"}, {"minLength", 1}, {"description", "file or folder, relative to survey.json"}}}}}};
}

}  // namespace

nlohmann::json BuildSurveySchema(const StageRegistry& registry) {
  nlohmann::json frames = PathInput("stereo frames: a folder in one of the supported layouts (docs/formats.md)");
  frames["properties"]["layout"] = {
      {"type", "string"},
      {"default", "auto"},
      {"description", "folder layout; auto detects it"},
      {"enum", nlohmann::json(std::vector<std::string>(std::begin(kFrameLayouts), std::end(kFrameLayouts)))}};
  nlohmann::json calibration =
      PathInput("stereo calibration file (docs/formats.md); optional when the layout carries one");
  nlohmann::json log = PathInput("flight log with GNSS (and attitude, camera events) for georeferencing");
  log["properties"]["format"] = {
      {"type", "string"},
      {"default", "auto"},
      {"description", "log format; auto detects it"},
      {"enum", nlohmann::json(std::vector<std::string>(std::begin(kFlightLogFormats), std::end(kFlightLogFormats)))}};
  log["properties"]["clock_offset_s"] = {
      {"type", "number"},
      {"default", 0.0},
      {"description", "camera clock minus log clock, seconds (added to log times before matching)"}};

  nlohmann::json stages = {{"type", "object"},
                           {"description", "per-stage options; every key is documented by `roadsurvey stages`"},
                           {"additionalProperties", false},
                           {"properties", nlohmann::json::object()}};
  for (const auto& stage : registry.stages())
    stages["properties"][stage->info().name] = stage->options().Schema(stage->info().doc);

  return {
      {"$schema", "http://json-schema.org/draft-07/schema#"},
      {"title", "roadsurvey survey file"},
      {"type", "object"},
      {"additionalProperties", false},
      {"required", {"name", "inputs", "output"}},
      {"properties",
       {{"$schema", {{"type", "string"}, {"description", "path of this schema, for editors"}}},
        {"name", {{"type", "string"}, {"pattern", "^[A-Za-z0-9_.-]+$"}, {"description", "survey name"}}},
        {"description", {{"type", "string"}, {"description", "free text"}}},
        {"inputs",
         {{"type", "object"},
          {"additionalProperties", false},
          {"required", {"frames"}},
          {"properties", {{"frames", frames}, {"calibration", calibration}, {"flight_log", log}}}}},
        {"output", {{"type", "string"}, {"minLength", 1}, {"description", "output folder, relative to survey.json"}}},
        {"crs",
         {{"type", "string"},
          {"default", "utm"},
          {"pattern", "^(utm|enu|EPSG:[0-9]{4,5})$"},
          {"description",
           "output CRS: utm (zone of the survey), enu (local tangent plane at the first fix) or EPSG:<code>"}}},
        {"stages", stages}}}};
}

}  // namespace rs
