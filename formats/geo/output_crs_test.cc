#include "formats/geo/output_crs.h"

#include <gtest/gtest.h>

#include <iomanip>
#include <optional>

#include <GeographicLib/LocalCartesian.hpp>

#include <array>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

namespace rs {
namespace {

// Runs cs2cs from WGS84 (EPSG:4979, lat lon h) to `target` on the points; nullopt when cs2cs is absent.
std::optional<std::vector<Eigen::Vector3d>> Cs2cs(const std::string& target, const std::vector<Geodetic>& points) {
  std::ostringstream cmd;
  cmd << "printf '";
  for (const auto& p : points) cmd << std::setprecision(15) << p.lat_deg << ' ' << p.lon_deg << ' ' << p.h_ellipsoid_m << "\\n";
  cmd << "' | cs2cs -f %.9f EPSG:4979 " << target << " 2>/dev/null";
  FILE* pipe = ::popen(cmd.str().c_str(), "r");
  if (!pipe) return std::nullopt;
  std::vector<Eigen::Vector3d> out;
  std::array<char, 512> line;
  while (std::fgets(line.data(), line.size(), pipe)) {
    Eigen::Vector3d v;
    if (std::sscanf(line.data(), "%lf %lf %lf", &v.x(), &v.y(), &v.z()) == 3) out.push_back(v);
  }
  if (::pclose(pipe) != 0 || out.size() != points.size()) return std::nullopt;
  return out;
}

const std::vector<Geodetic> kLondon = {{51.5007, -0.1246, 45.0}, {51.4, -0.3, 120.5}, {50.9, 1.2, 10.0}};
const std::vector<Geodetic> kLjubljana = {{46.0569, 14.5058, 300.0}, {46.06, 14.51, 310.25}, {45.9, 14.2, 500.0}};

void ExpectAgreesWithCs2cs(const OutputCrs& crs, const std::vector<Geodetic>& points, bool geographic_out = false) {
  const auto ref = Cs2cs(crs.epsg(), points);
  if (!ref) GTEST_SKIP() << "cs2cs (proj-bin) not installed: cannot compare with PROJ's command line";
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d ours = crs.Forward(points[i]);
    // cs2cs prints projected CRSs as easting northing; geographic ones as lat lon.
    const Eigen::Vector3d want = geographic_out ? Eigen::Vector3d((*ref)[i].y(), (*ref)[i].x(), (*ref)[i].z()) : (*ref)[i];
    const double tol_xy = geographic_out ? 1e-8 : 1e-3;  // 1 mm; 1e-8 deg is ~1 mm
    EXPECT_NEAR(ours.x(), want.x(), tol_xy) << crs.epsg() << " point " << i;
    EXPECT_NEAR(ours.y(), want.y(), tol_xy) << crs.epsg() << " point " << i;
    EXPECT_NEAR(ours.z(), want.z(), 1e-3) << crs.epsg() << " point " << i;
  }
}

TEST(OutputCrs, BritishNationalGridAgreesWithCs2cs) {
  const OutputCrs crs("EPSG:27700", kLondon[0], HeightReference::kEllipsoid);
  EXPECT_EQ(crs.epsg(), "EPSG:27700");
  EXPECT_NE(crs.wkt().find("OSGB"), std::string::npos);
  ExpectAgreesWithCs2cs(crs, kLondon);
}

TEST(OutputCrs, BritishNationalGridWithGeoidHeightsAgreesWithCs2cs) {
  const OutputCrs crs("EPSG:27700", kLondon[0], HeightReference::kGeoidEgm96);
  EXPECT_EQ(crs.epsg(), "EPSG:27700+5773");
  ExpectAgreesWithCs2cs(crs, kLondon);
  // EGM96 lies ~46-47 m above the ellipsoid around London.
  EXPECT_NEAR(crs.Forward(kLondon[0]).z(), 45.0 - 46.4, 1.0);
}

TEST(OutputCrs, UtmZoneOfTheCentreAgreesWithCs2cs) {
  const OutputCrs crs("utm", kLjubljana[0], HeightReference::kEllipsoid);
  EXPECT_EQ(crs.epsg(), "EPSG:32633");
  ExpectAgreesWithCs2cs(crs, kLjubljana);
  const OutputCrs south("utm", {-33.9, 151.2, 0}, HeightReference::kEllipsoid);  // Sydney
  EXPECT_EQ(south.epsg(), "EPSG:32756");
  EXPECT_EQ(UtmZone(60.5, 4.5), 32);  // the Norway exception
}

TEST(OutputCrs, UtmWithGeoidHeightsAgreesWithCs2cs) {
  const OutputCrs crs("utm", kLjubljana[0], HeightReference::kGeoidEgm96);
  ExpectAgreesWithCs2cs(crs, kLjubljana);
}

TEST(OutputCrs, GeographicCrsAgreesWithCs2cs) {
  const OutputCrs crs("EPSG:4326", kLjubljana[0], HeightReference::kGeoidEgm96);
  ExpectAgreesWithCs2cs(crs, kLjubljana, /*geographic_out=*/true);
}

TEST(OutputCrs, Egm96UndulationMatchesCs2cs) {
  const auto ref = Cs2cs("EPSG:4326+5773", kLjubljana);
  if (!ref) GTEST_SKIP() << "cs2cs (proj-bin) not installed";
  for (size_t i = 0; i < kLjubljana.size(); ++i)
    EXPECT_NEAR(kLjubljana[i].h_ellipsoid_m - Egm96UndulationM(kLjubljana[i].lat_deg, kLjubljana[i].lon_deg),
                (*ref)[i].z(), 1e-3);
}

TEST(OutputCrs, LocalEnuIsTheTangentPlaneAtTheOrigin) {
  const Geodetic origin{46.0569, 14.5058, 300.0};
  const OutputCrs crs("enu", origin, HeightReference::kEllipsoid);
  EXPECT_TRUE(crs.is_local_enu());
  EXPECT_TRUE(crs.epsg().empty());
  EXPECT_NEAR(crs.Forward(origin).norm(), 0.0, 1e-9);
  // 100 m north along the meridian, 2 m up: GeographicLib's own reverse gives the geodetic point.
  GeographicLib::LocalCartesian lc(origin.lat_deg, origin.lon_deg, origin.h_ellipsoid_m);
  Geodetic p;
  lc.Reverse(0, 100, 2, p.lat_deg, p.lon_deg, p.h_ellipsoid_m);
  const Eigen::Vector3d x = crs.Forward(p);
  EXPECT_NEAR(x.x(), 0, 1e-6);
  EXPECT_NEAR(x.y(), 100, 1e-6);
  EXPECT_NEAR(x.z(), 2, 1e-6);
  EXPECT_GT(p.lat_deg, origin.lat_deg + 100 / 111300.0 - 1e-5);  // ~1 m per 1e-5 deg of latitude
}

TEST(OutputCrs, BadSpecNamesTheSpec) {
  const Geodetic c{46, 14, 0};
  for (const std::string bad : {"utm33", "EPSG:", "EPSG:12x", "EPSG:999999", "EPSG:5773"}) {
    try {
      OutputCrs crs(bad, c, HeightReference::kEllipsoid);
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(OutputCrs("enu", c, HeightReference::kGeoidEgm96), std::invalid_argument);
}

}  // namespace
}  // namespace rs
