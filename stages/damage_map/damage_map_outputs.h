#pragma once
// The damage map's files: damage.geojson (RFC 7946, WGS84), damage.csv (the same fields plus
// coordinates in the survey CRS), QGIS styles and a thumbnail per damage.

#include <filesystem>
#include <vector>

#include <GeographicLib/LocalCartesian.hpp>
#include <nlohmann/json.hpp>

#include "formats/geo/output_crs.h"
#include "stages/damage_map/mapped_damage.h"

namespace rs {

/// The feature properties of one damage (the GeoJSON's and the CSV's fields).
nlohmann::json DamageProperties(const MappedDamage& damage, const std::vector<MapObservation>& obs);

void WriteDamageGeoJson(const std::filesystem::path& path, const std::vector<MappedDamage>& damages,
                        const std::vector<MapObservation>& obs, const GeographicLib::LocalCartesian& enu);

/// One row per damage; the centroid as easting/northing/height in `crs` and WGS84.
void WriteDamageCsv(const std::filesystem::path& path, const std::vector<MappedDamage>& damages,
                    const std::vector<MapObservation>& obs, const GeographicLib::LocalCartesian& enu,
                    const OutputCrs& crs);

/// damage.qml (polygons) and damage_cracks.qml (lines): colour by severity, label by id.
void WriteQgisStyles(const std::filesystem::path& dir);

/// A crop of the best view's left image around the damage, its outline drawn; JPEG.
void WriteThumbnail(const std::filesystem::path& path, const std::filesystem::path& left_image,
                    const MapObservation& best);

}  // namespace rs
