#include "formats/geojson/geojson.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "formats/checked_file.h"
#include "formats/input_error.h"

namespace rs::geojson {
namespace {

void CheckPosition(const Position& p) {
  if (!std::isfinite(p.lon_deg) || !std::isfinite(p.lat_deg) || p.lon_deg < -180 || p.lon_deg > 180 ||
      p.lat_deg < -90 || p.lat_deg > 90 || (p.h_m && !std::isfinite(*p.h_m))) {
    throw std::invalid_argument(
        fmt::format("GeoJSON position ({}, {}) is not a finite WGS84 lon/lat", p.lon_deg, p.lat_deg));
  }
}

bool SameXY(const Position& a, const Position& b) { return a.lon_deg == b.lon_deg && a.lat_deg == b.lat_deg; }

/// Closed copy of `ring`, oriented CCW when `ccw` else CW.
Ring NormalizedRing(const Ring& ring, bool ccw) {
  for (const auto& p : ring) CheckPosition(p);
  Ring r = ring;
  if (r.size() >= 2 && SameXY(r.front(), r.back())) r.pop_back();
  if (r.size() < 3) throw std::invalid_argument("GeoJSON ring needs at least 3 distinct positions");
  const double area = SignedAreaDeg2(r);
  if (area == 0) throw std::invalid_argument("GeoJSON ring has zero area");
  if ((area > 0) != ccw) std::reverse(r.begin(), r.end());
  r.push_back(r.front());
  return r;
}

void WritePosition(std::string& s, const Position& p) {
  s += fmt::format("[{:.{}f},{:.{}f}", p.lon_deg, kGeoJsonDecimals, p.lat_deg, kGeoJsonDecimals);
  if (p.h_m) s += fmt::format(",{:.4f}", *p.h_m);
  s += ']';
}

void WritePositions(std::string& s, const std::vector<Position>& ps) {
  s += '[';
  for (size_t i = 0; i < ps.size(); ++i) {
    if (i) s += ',';
    WritePosition(s, ps[i]);
  }
  s += ']';
}

void WritePolygonCoords(std::string& s, const Polygon& polygon) {
  const Polygon n = Normalized(polygon);
  s += '[';
  for (size_t i = 0; i < n.rings.size(); ++i) {
    if (i) s += ',';
    WritePositions(s, n.rings[i]);
  }
  s += ']';
}

void WriteGeometry(std::string& s, const Geometry& g) {
  if (const auto* p = std::get_if<Point>(&g)) {
    CheckPosition(p->position);
    s += R"({"type":"Point","coordinates":)";
    WritePosition(s, p->position);
  } else if (const auto* l = std::get_if<LineString>(&g)) {
    if (l->positions.size() < 2) throw std::invalid_argument("GeoJSON LineString needs at least 2 positions");
    for (const auto& q : l->positions) CheckPosition(q);
    s += R"({"type":"LineString","coordinates":)";
    WritePositions(s, l->positions);
  } else if (const auto* pg = std::get_if<Polygon>(&g)) {
    s += R"({"type":"Polygon","coordinates":)";
    WritePolygonCoords(s, *pg);
  } else {
    const auto& mp = std::get<MultiPolygon>(g);
    if (mp.polygons.empty()) throw std::invalid_argument("GeoJSON MultiPolygon needs at least 1 polygon");
    s += R"({"type":"MultiPolygon","coordinates":[)";
    for (size_t i = 0; i < mp.polygons.size(); ++i) {
      if (i) s += ',';
      WritePolygonCoords(s, mp.polygons[i]);
    }
    s += ']';
  }
  s += '}';
}

// ---- reading ----

[[noreturn]] void Fail(const std::string& path, const std::string& msg) {
  throw InputError(InputLocation::File(path), msg);
}

Position ReadPosition(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array() || j.size() < 2 || j.size() > 3) Fail(path, "a position must be an array of 2 or 3 numbers");
  for (const auto& v : j) {
    if (!v.is_number()) Fail(path, "a position must be an array of 2 or 3 numbers");
  }
  Position p{j[0].get<double>(), j[1].get<double>(), std::nullopt};
  if (j.size() == 3) p.h_m = j[2].get<double>();
  if (p.lon_deg < -180 || p.lon_deg > 180 || p.lat_deg < -90 || p.lat_deg > 90) {
    Fail(path, fmt::format("position ({}, {}) is outside WGS84 lon/lat range", p.lon_deg, p.lat_deg));
  }
  return p;
}

std::vector<Position> ReadPositions(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array()) Fail(path, "expected an array of positions");
  std::vector<Position> out;
  out.reserve(j.size());
  for (const auto& p : j) out.push_back(ReadPosition(p, path));
  return out;
}

Polygon ReadPolygon(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array() || j.empty()) Fail(path, "a Polygon needs at least one ring");
  Polygon pg;
  for (const auto& r : j) {
    Ring ring = ReadPositions(r, path);
    if (ring.size() < 4 || !SameXY(ring.front(), ring.back())) {
      Fail(path, "a Polygon ring must be closed and have at least 4 positions");
    }
    pg.rings.push_back(std::move(ring));
  }
  return pg;
}

Geometry ReadGeometry(const nlohmann::json& j, const std::string& path) {
  if (!j.is_object() || !j.contains("type") || !j["type"].is_string() || !j.contains("coordinates")) {
    Fail(path, "a geometry needs string \"type\" and \"coordinates\"");
  }
  const std::string type = j["type"].get<std::string>();
  const auto& c = j["coordinates"];
  if (type == "Point") return Point{ReadPosition(c, path)};
  if (type == "LineString") {
    LineString l{ReadPositions(c, path)};
    if (l.positions.size() < 2) Fail(path, "a LineString needs at least 2 positions");
    return l;
  }
  if (type == "Polygon") return ReadPolygon(c, path);
  if (type == "MultiPolygon") {
    if (!c.is_array()) Fail(path, "MultiPolygon coordinates must be an array");
    MultiPolygon mp;
    for (const auto& p : c) mp.polygons.push_back(ReadPolygon(p, path));
    return mp;
  }
  Fail(path, "unsupported geometry type \"" + type + "\"");
}

}  // namespace

double SignedAreaDeg2(const Ring& ring) {
  // Relative to the first vertex: avoids cancellation for small rings far from (0, 0).
  double a = 0;
  const size_t n = ring.size();
  if (n == 0) return 0;
  const double x0 = ring[0].lon_deg, y0 = ring[0].lat_deg;
  for (size_t i = 0; i < n; ++i) {
    const Position& p = ring[i];
    const Position& q = ring[(i + 1) % n];
    a += (p.lon_deg - x0) * (q.lat_deg - y0) - (q.lon_deg - x0) * (p.lat_deg - y0);
  }
  return 0.5 * a;
}

Polygon Normalized(const Polygon& polygon) {
  if (polygon.rings.empty()) throw std::invalid_argument("GeoJSON Polygon needs an exterior ring");
  Polygon out;
  for (size_t i = 0; i < polygon.rings.size(); ++i) out.rings.push_back(NormalizedRing(polygon.rings[i], i == 0));
  return out;
}

void WriteFeatureCollection(std::ostream& out, const FeatureCollection& collection) {
  std::string s = R"({"type":"FeatureCollection","features":[)";
  for (size_t i = 0; i < collection.features.size(); ++i) {
    const Feature& f = collection.features[i];
    if (!f.properties.is_object() && !f.properties.is_null()) {
      throw std::invalid_argument("GeoJSON Feature properties must be an object or null");
    }
    if (i) s += ',';
    s += R"({"type":"Feature",)";
    if (f.id) s += "\"id\":" + nlohmann::json(*f.id).dump() + ",";
    s += "\"geometry\":";
    WriteGeometry(s, f.geometry);
    s += ",\"properties\":" + f.properties.dump() + "}";
  }
  s += "]}\n";
  out << s;
}

void WriteFeatureCollection(const std::filesystem::path& path, const FeatureCollection& collection) {
  WriteStreamChecked(path, [&](std::ostream& out) { WriteFeatureCollection(out, collection); });
}

FeatureCollection ReadFeatureCollection(std::istream& in, const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(InputLocation::Byte(path, static_cast<int64_t>(e.byte)), "malformed JSON");
  }
  if (!j.is_object() || j.value("type", "") != "FeatureCollection" || !j.contains("features") ||
      !j["features"].is_array()) {
    Fail(path, "expected a FeatureCollection with a \"features\" array");
  }
  if (j.contains("crs")) Fail(path, "RFC 7946 forbids the \"crs\" member (coordinates are always WGS84)");
  FeatureCollection fc;
  for (const auto& f : j["features"]) {
    if (!f.is_object() || f.value("type", "") != "Feature" || !f.contains("geometry")) {
      Fail(path, "each feature must be a \"Feature\" object with a geometry");
    }
    Feature out{ReadGeometry(f["geometry"], path)};
    if (f.contains("properties")) {
      if (!f["properties"].is_object() && !f["properties"].is_null())
        Fail(path, "properties must be an object or null");
      out.properties = f["properties"];
    }
    if (f.contains("id")) {
      if (f["id"].is_string())
        out.id = f["id"].get<std::string>();
      else if (f["id"].is_number())
        out.id = f["id"].dump();
      else
        Fail(path, "a Feature id must be a string or number");
    }
    fc.features.push_back(std::move(out));
  }
  return fc;
}

FeatureCollection ReadFeatureCollection(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadFeatureCollection(f, path.string());
}

}  // namespace rs::geojson
