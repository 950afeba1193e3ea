#include "formats/geojson/geojson.h"

#include <gtest/gtest.h>

#include <regex>
#include <sstream>

#include "formats/input_error.h"

namespace rs::geojson {
namespace {

Polygon Square(double lon0, double lat0, double side, bool ccw) {
  Ring r{{lon0, lat0}, {lon0 + side, lat0}, {lon0 + side, lat0 + side}, {lon0, lat0 + side}};
  if (!ccw) std::reverse(r.begin(), r.end());
  return Polygon{{r}};
}

std::string Write(const FeatureCollection& fc) {
  std::ostringstream ss;
  WriteFeatureCollection(ss, fc);
  return ss.str();
}

TEST(GeoJson, Nominal) {
  FeatureCollection fc;
  fc.features.push_back({Point{{14.123456789, 46.5}}, {{"type", "marker"}}, "p1"});
  fc.features.push_back({LineString{{{14.0, 46.0}, {14.00001, 46.00002, 300.25}}}, {{"width_m", 0.012}}});
  Polygon hole_cw = Square(14.0, 46.0, 1e-4, /*ccw=*/false);
  hole_cw.rings.push_back(Square(14.00002, 46.00002, 2e-5, /*ccw=*/true).rings[0]);
  fc.features.push_back({hole_cw, {{"area_m2", 1.5}}});
  fc.features.push_back({MultiPolygon{{Square(15, 47, 1e-5, true), Square(15.1, 47.1, 1e-5, false)}}, nullptr});

  const std::string text = Write(fc);
  EXPECT_EQ(text.find("crs"), std::string::npos);
  // Every coordinate number has exactly 8 decimals (heights 4).
  std::regex num(R"(\[(-?\d+\.\d+),(-?\d+\.\d+))");
  int count = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), num); it != std::sregex_iterator(); ++it) {
    for (int g = 1; g <= 2; ++g) {
      const std::string s = (*it)[g];
      EXPECT_EQ(s.size() - s.find('.') - 1, 8u) << s;
    }
    ++count;
  }
  EXPECT_GT(count, 10);
  EXPECT_NE(text.find("14.12345679"), std::string::npos);  // rounded, not truncated

  std::istringstream in(text);
  const FeatureCollection back = ReadFeatureCollection(in, "mem.geojson");
  ASSERT_EQ(back.features.size(), 4u);
  EXPECT_EQ(*back.features[0].id, "p1");
  EXPECT_EQ(back.features[0].properties["type"], "marker");
  EXPECT_NEAR(std::get<Point>(back.features[0].geometry).position.lon_deg, 14.123456789, 5e-9);
  const auto& ls = std::get<LineString>(back.features[1].geometry);
  ASSERT_EQ(ls.positions.size(), 2u);
  EXPECT_NEAR(*ls.positions[1].h_m, 300.25, 1e-9);
  const auto& pg = std::get<Polygon>(back.features[2].geometry);
  ASSERT_EQ(pg.rings.size(), 2u);
  // Right-hand rule: exterior CCW, hole CW, rings closed.
  EXPECT_GT(SignedAreaDeg2(pg.rings[0]), 0);
  EXPECT_LT(SignedAreaDeg2(pg.rings[1]), 0);
  for (const auto& r : pg.rings) {
    ASSERT_EQ(r.size(), 5u);
    EXPECT_EQ(r.front().lon_deg, r.back().lon_deg);
    EXPECT_EQ(r.front().lat_deg, r.back().lat_deg);
  }
  EXPECT_NEAR(SignedAreaDeg2(pg.rings[0]), 1e-8, 1e-14);
  const auto& mp = std::get<MultiPolygon>(back.features[3].geometry);
  ASSERT_EQ(mp.polygons.size(), 2u);
  for (const auto& p : mp.polygons) EXPECT_GT(SignedAreaDeg2(p.rings[0]), 0);
  EXPECT_TRUE(back.features[3].properties.is_null());

  // Writing what was read gives the same text (round-trip is a fixed point).
  EXPECT_EQ(Write(back), text);
}

TEST(GeoJson, InvalidGeometry) {
  FeatureCollection fc;
  fc.features.push_back({Point{{200, 0}}});
  EXPECT_THROW(Write(fc), std::invalid_argument);
  fc.features[0].geometry = Polygon{{{{0, 0}, {1, 1}, {0, 0}}}};
  EXPECT_THROW(Write(fc), std::invalid_argument);
  fc.features[0].geometry = LineString{{{0, 0}}};
  EXPECT_THROW(Write(fc), std::invalid_argument);
  fc.features[0].geometry = Point{{0, std::nan("")}};
  EXPECT_THROW(Write(fc), std::invalid_argument);
  fc.features[0] = {Point{{0, 0}}, nlohmann::json::array()};
  EXPECT_THROW(Write(fc), std::invalid_argument);
}

TEST(GeoJson, MalformedInput) {
  auto read = [](const std::string& s) {
    std::istringstream in(s);
    return ReadFeatureCollection(in, "bad.geojson");
  };
  try {
    read(R"({"type":"FeatureCollection","features":[)");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, "bad.geojson");
    EXPECT_GE(e.where().byte_offset, 0);
  }
  EXPECT_THROW(read(R"({"type":"Feature"})"), InputError);
  EXPECT_THROW(read(R"({"type":"FeatureCollection","crs":{},"features":[]})"), InputError);
  EXPECT_THROW(
      read(
          R"({"type":"FeatureCollection","features":[{"type":"Feature","geometry":{"type":"Circle","coordinates":[0,0]}}]})"),
      InputError);
  EXPECT_THROW(
      read(
          R"({"type":"FeatureCollection","features":[{"type":"Feature","geometry":{"type":"Point","coordinates":[0,95]}}]})"),
      InputError);
  EXPECT_THROW(
      read(
          R"({"type":"FeatureCollection","features":[{"type":"Feature","geometry":{"type":"Polygon","coordinates":[[[0,0],[1,0],[1,1]]]}}]})"),
      InputError);
  EXPECT_EQ(read(R"({"type":"FeatureCollection","features":[]})").features.size(), 0u);
}

}  // namespace
}  // namespace rs::geojson
