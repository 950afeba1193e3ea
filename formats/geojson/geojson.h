#pragma once
// GDAL-free GeoJSON (RFC 7946) writer and reader for damage polygons.
//
// Writing normalizes what RFC 7946 requires so callers cannot get it wrong:
// WGS84 longitude/latitude (no `crs` member), rings closed (first == last),
// exterior rings counter-clockwise and holes clockwise (right-hand rule, section
// 3.1.6), coordinates with exactly `kGeoJsonDecimals` decimals (8 decimals of a
// degree is about 1 mm, enough for centimetre geometry).

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

namespace rs::geojson {

/// Decimals written for every coordinate.
inline constexpr int kGeoJsonDecimals = 8;

/// One position: WGS84 longitude and latitude in degrees, optional ellipsoidal height.
struct Position {
  double lon_deg = 0;
  double lat_deg = 0;
  std::optional<double> h_m = std::nullopt;  ///< written as the third coordinate when set
};

/// A closed or open ring; the writer closes it.
using Ring = std::vector<Position>;

struct Point {
  Position position;
};
struct LineString {
  std::vector<Position> positions;  ///< at least 2
};
/// rings[0] is the exterior, the rest are holes.
struct Polygon {
  std::vector<Ring> rings;
};
struct MultiPolygon {
  std::vector<Polygon> polygons;
};

using Geometry = std::variant<Point, LineString, Polygon, MultiPolygon>;

/// A GeoJSON Feature. `properties` must be a JSON object (or null).
struct Feature {
  Geometry geometry;
  nlohmann::json properties = nlohmann::json::object();
  std::optional<std::string> id = std::nullopt;  ///< optional Feature "id" member
};

struct FeatureCollection {
  std::vector<Feature> features;
};

/// Signed area of a ring in squared degrees (shoelace on lon/lat): > 0 means
/// counter-clockwise. Closing point optional.
double SignedAreaDeg2(const Ring& ring);

/// The normalized form the writer emits: ring closed, exterior CCW, holes CW.
/// Throws std::invalid_argument on a non-finite or out-of-range coordinate, a
/// ring with fewer than 3 distinct positions, or a LineString with < 2 positions.
Polygon Normalized(const Polygon& polygon);

/// Writes a FeatureCollection as compact RFC 7946 GeoJSON text (one line).
/// Throws std::invalid_argument on invalid geometry (see Normalized()) or
/// properties that are neither an object nor null.
void WriteFeatureCollection(std::ostream& out, const FeatureCollection& collection);
/// Writes to `path`; throws std::runtime_error if the file cannot be written.
void WriteFeatureCollection(const std::filesystem::path& path, const FeatureCollection& collection);

/// Reads a FeatureCollection (Point, LineString, Polygon, MultiPolygon geometries).
/// `path` names the input in errors. Throws rs::InputError on malformed JSON
/// (with the byte offset), a missing/ill-typed member, an unsupported geometry
/// type, a `crs` member (forbidden by RFC 7946) or an out-of-range coordinate.
FeatureCollection ReadFeatureCollection(std::istream& in, const std::string& path);
FeatureCollection ReadFeatureCollection(const std::filesystem::path& path);

}  // namespace rs::geojson
