#include "formats/damage/detections_file.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <limits>

#include "formats/input_error.h"

namespace rs {
namespace {

constexpr const char* kSchema = "roadsurvey.damage_detections/1";

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw InputError(InputLocation::File(path), what);
}

double Number(const nlohmann::json& d, const char* key, const std::string& path, size_t index) {
  const auto it = d.find(key);
  if (it == d.end()) Fail(path, fmt::format("detection {}: no \"{}\"", index, key));
  if (it->is_null()) return std::numeric_limits<double>::quiet_NaN();
  if (!it->is_number()) Fail(path, fmt::format("detection {}: \"{}\" is not a number", index, key));
  return it->get<double>();
}

DamageDetection ReadDetection(const nlohmann::json& d, const std::string& path, size_t index) {
  if (!d.is_object()) Fail(path, fmt::format("detection {} is not an object", index));
  DamageDetection out;
  const auto num = [&](const char* key) { return Number(d, key, path, index); };
  out.id = static_cast<int>(num("id"));
  const auto type = d.find("type");
  if (type == d.end() || !type->is_string()) Fail(path, fmt::format("detection {}: no \"type\" string", index));
  out.type = type->get<std::string>();
  out.pixel_count = static_cast<int>(num("pixel_count"));
  out.area_m2 = num("area_m2");
  out.sigma_area_m2 = num("sigma_area_m2");
  out.max_depth_m = num("max_depth_m");
  out.max_depth_seen_m = num("max_depth_seen_m");
  out.max_depth_bound_m = num("max_depth_bound_m");
  out.mean_depth_m = num("mean_depth_m");
  out.volume_m3 = num("volume_m3");
  out.volume_seen_m3 = num("volume_seen_m3");
  out.volume_upper_m3 = num("volume_upper_m3");
  out.sigma_volume_m3 = num("sigma_volume_m3");
  out.equivalent_diameter_m = num("equivalent_diameter_m");
  out.max_diameter_m = num("max_diameter_m");
  out.length_m = num("length_m");
  out.mean_width_m = num("mean_width_m");
  out.max_width_m = num("max_width_m");
  out.range_m = num("range_m");
  out.sigma_depth_m = num("sigma_depth_m");
  out.confidence = num("confidence");
  const auto visible = d.find("floor_visible");
  if (visible == d.end() || !visible->is_boolean())
    Fail(path, fmt::format("detection {}: no \"floor_visible\" boolean", index));
  out.floor_visible = visible->get<bool>();
  const auto px = d.find("outline_px");
  const auto cam = d.find("outline_cam_m");
  if (px == d.end() || !px->is_array() || cam == d.end() || !cam->is_array())
    Fail(path, fmt::format("detection {}: \"outline_px\" and \"outline_cam_m\" must be arrays", index));
  for (const auto& p : *px) {
    if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
      Fail(path, fmt::format("detection {}: an outline_px point is not [u, v]", index));
    out.outline_px.emplace_back(p[0].get<int>(), p[1].get<int>());
  }
  for (const auto& p : *cam) {
    if (!p.is_array() || p.size() != 3 || !p[0].is_number() || !p[1].is_number() || !p[2].is_number())
      Fail(path, fmt::format("detection {}: an outline_cam_m point is not [x, y, z]", index));
    out.outline_cam.emplace_back(p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  }
  return out;
}

}  // namespace

FrameDetections ReadFrameDetections(std::istream& in, const std::string& path) {
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) Fail(path, "not a JSON object (malformed or truncated)");
  if (j.value("schema", std::string()) != kSchema)
    Fail(path, fmt::format("schema is not \"{}\"", kSchema));
  FrameDetections out;
  if (!j.contains("frame") || !j["frame"].is_number_integer()) Fail(path, "no integer \"frame\"");
  out.frame = j["frame"].get<int64_t>();
  out.t_ns = j.value("t_ns", int64_t{0});
  if (const auto r = j.find("analysed_range_m"); r != j.end() && !r->is_null()) {
    if (!r->is_number() || !(r->get<double>() > 0)) Fail(path, "\"analysed_range_m\" is not a positive number or null");
    out.analysed_range_m = r->get<double>();
  }
  const auto list = j.find("detections");
  if (list == j.end() || !list->is_array()) Fail(path, "no \"detections\" array");
  for (size_t i = 0; i < list->size(); ++i) out.detections.push_back(ReadDetection((*list)[i], path, i));
  return out;
}

FrameDetections ReadFrameDetections(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open");
  return ReadFrameDetections(in, path.string());
}

}  // namespace rs
