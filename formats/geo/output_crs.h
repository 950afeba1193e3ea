#pragma once
// Output coordinate reference systems of a survey (SurveyFile::crs): "utm" (the zone of the
// survey's centre), "enu" (local tangent plane at a stated origin) or "EPSG:<code>" (any CRS PROJ
// knows). Input positions are always WGS84 latitude, longitude and ellipsoidal height.
//
// Projected and geographic CRSs go through PROJ (the same operation cs2cs picks); the local
// tangent plane through GeographicLib::LocalCartesian. Heights state their reference: WGS84
// ellipsoidal height, or height above the EGM96 geoid (EPSG:5773, grid from proj-data).
// Kept in the base layer because every stage that writes coordinates needs the same conversion.

#include <memory>
#include <string>

#include <Eigen/Core>

namespace rs {

/// What output heights are measured from.
enum class HeightReference {
  kEllipsoid,  ///< WGS84 ellipsoidal height (for "enu": the tangent plane's up axis)
  kGeoidEgm96  ///< orthometric height above the EGM96 geoid (EPSG:5773)
};
const char* ToString(HeightReference h);

/// A WGS84 geodetic position.
struct Geodetic {
  double lat_deg = 0, lon_deg = 0;
  double h_ellipsoid_m = 0;
};

/// One output CRS, ready to convert positions. Not copyable (owns PROJ objects); movable.
class OutputCrs {
 public:
  /// `spec` is "utm", "enu" or "EPSG:<code>". `centre` chooses the UTM zone and, for "enu",
  /// is the tangent plane's origin. Throws std::invalid_argument naming the spec when PROJ
  /// does not know the CRS or the combination is impossible (geoid heights with "enu").
  OutputCrs(const std::string& spec, const Geodetic& centre, HeightReference heights);
  ~OutputCrs();
  OutputCrs(OutputCrs&&) noexcept;
  OutputCrs& operator=(OutputCrs&&) noexcept;

  /// Easting/x, northing/y (m, or degrees for a geographic CRS) and height in this CRS.
  Eigen::Vector3d Forward(const Geodetic& p) const;

  const std::string& spec() const;
  /// "EPSG:32633", "EPSG:27700+5773"; empty for "enu".
  const std::string& epsg() const;
  /// The CRS as WKT2 (2019); for "enu" a description of the tangent plane.
  const std::string& wkt() const;
  HeightReference heights() const;
  /// The origin of "enu" (also set for the other kinds: the centre passed in).
  const Geodetic& origin() const;
  bool is_local_enu() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Height of the EGM96 geoid above the WGS84 ellipsoid at a position, m (PROJ, egm96 grid).
/// Converts an above-mean-sea-level altitude to ellipsoidal: h = H + N. Throws std::runtime_error
/// when the geoid grid is missing (install proj-data).
double Egm96UndulationM(double lat_deg, double lon_deg);

/// The UTM zone (1..60) of a position (GeographicLib's standard zone, Norway/Svalbard rules included).
int UtmZone(double lat_deg, double lon_deg);

}  // namespace rs
