#include "formats/geo/georeference_file.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <fstream>

#include "formats/input_error.h"

namespace rs {
namespace {

[[noreturn]] void Fail(const std::filesystem::path& path, const std::string& what) {
  throw InputError(InputLocation::File(path.string()), what);
}

const nlohmann::json& Member(const nlohmann::json& j, const char* key, const std::filesystem::path& path) {
  const auto it = j.find(key);
  if (it == j.end()) Fail(path, fmt::format("no \"{}\"", key));
  return *it;
}

double Number(const nlohmann::json& j, const char* key, const std::filesystem::path& path) {
  const auto& v = Member(j, key, path);
  if (!v.is_number()) Fail(path, fmt::format("\"{}\" is not a number", key));
  return v.get<double>();
}

Geodetic ReadGeodetic(const nlohmann::json& j, const std::filesystem::path& path) {
  return {Number(j, "lat_deg", path), Number(j, "lon_deg", path), Number(j, "h_ellipsoid_m", path)};
}

}  // namespace

std::unique_ptr<OutputCrs> GeoreferenceFile::MakeCrs() const {
  return std::make_unique<OutputCrs>(crs_spec, crs_origin, heights);
}

GeoreferenceFile ReadGeoreferenceFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) Fail(path, "cannot open");
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) Fail(path, "not a JSON object (malformed or truncated)");
  if (j.value("format", std::string()) != "roadsurvey-georeference-v1")
    Fail(path, "format is not \"roadsurvey-georeference-v1\"");
  GeoreferenceFile g;
  g.georeferenced = j.value("georeferenced", false);
  if (!g.georeferenced) {
    g.reason = j.value("reason", std::string("not georeferenced"));
    return g;
  }
  g.origin = ReadGeodetic(Member(j, "origin", path), path);
  const auto& tf = Member(j, "transform", path);
  g.scale = Number(tf, "scale", path);
  const auto& R = Member(tf, "R_row_major", path);
  const auto& t = Member(tf, "t_m", path);
  if (!R.is_array() || R.size() != 9 || !t.is_array() || t.size() != 3)
    Fail(path, "transform: R_row_major must hold 9 numbers and t_m 3");
  for (int i = 0; i < 9; ++i) g.R(i / 3, i % 3) = R[i].get<double>();
  for (int i = 0; i < 3; ++i) g.t[i] = t[i].get<double>();
  const auto& crs = Member(j, "crs", path);
  g.crs_spec = crs.value("spec", std::string());
  if (g.crs_spec.empty()) Fail(path, "crs: no \"spec\"");
  g.heights = crs.value("heights", std::string()) == ToString(HeightReference::kGeoidEgm96)
                  ? HeightReference::kGeoidEgm96
                  : HeightReference::kEllipsoid;
  g.crs_origin = crs.contains("enu_origin") ? ReadGeodetic(crs["enu_origin"], path) : g.origin;
  if (j.contains("residuals") && j["residuals"].contains("robust_sigma_m")) {
    const auto& s = j["residuals"]["robust_sigma_m"];
    g.sigma_enu_m = {s.value("east", 0.0), s.value("north", 0.0), s.value("up", 0.0)};
  }
  return g;
}

}  // namespace rs
