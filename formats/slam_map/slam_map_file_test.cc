#include "formats/slam_map/slam_map_file.h"

#include <gtest/gtest.h>

#include <fstream>

#include "formats/input_error.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

SlamMapFile SmallMap() {
  SlamMapFile m;
  m.camera = {1280, 720, 1000, 1000, 640, 360, 0.3};
  m.scale_factor = 1.2;
  m.pyramid_levels = 8;
  for (int i = 0; i < 2; ++i) {
    SlamMapKeyframe k;
    k.id = i * 3;
    k.t_ns = 1700000000000000000 + i * 83333333;
    k.segment = 0;
    k.T_cam_world = Eigen::Translation3d(0.5 * i, -0.25, 6.0) * Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ());
    m.keyframes.push_back(k);
  }
  SlamMapPoint p;
  p.id = 7;
  p.p_world = {1.25, -2.5, 0.125};
  p.observations = {{0, 100.5, 200.25, 0, 90.125}, {3, 110.75, 201.5, 2, -1}};
  m.points.push_back(p);
  return m;
}

fs::path TempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("slam_map_test_" + name + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

TEST(SlamMapFile, RoundTripsEveryField) {
  const fs::path dir = TempDir("rt");
  const SlamMapFile in = SmallMap();
  WriteSlamMap(dir, in);
  const SlamMapFile out = ReadSlamMap(dir);
  EXPECT_EQ(out.camera.width, 1280);
  EXPECT_DOUBLE_EQ(out.camera.baseline_m, 0.3);
  ASSERT_EQ(out.keyframes.size(), 2u);
  EXPECT_EQ(out.keyframes[1].id, 3);
  EXPECT_EQ(out.keyframes[1].t_ns, in.keyframes[1].t_ns);
  EXPECT_TRUE(out.keyframes[1].T_cam_world.isApprox(in.keyframes[1].T_cam_world, 1e-12));
  ASSERT_EQ(out.points.size(), 1u);
  EXPECT_TRUE(out.points[0].p_world.isApprox(in.points[0].p_world, 1e-9));
  ASSERT_EQ(out.points[0].observations.size(), 2u);
  EXPECT_EQ(out.points[0].observations[1].keyframe, 3);
  EXPECT_EQ(out.points[0].observations[1].level, 2);
  EXPECT_DOUBLE_EQ(out.points[0].observations[0].u_right_px, 90.125);
  EXPECT_LT(out.points[0].observations[1].u_right_px, 0);
  EXPECT_NEAR(out.LevelSigmaPx(2), 1.44, 1e-12);
  fs::remove_all(dir);
}

void ExpectErrorAt(const fs::path& dir, const std::string& points_line, int64_t line, const std::string& what) {
  WriteSlamMap(dir, SmallMap());
  std::ofstream(dir / "points.txt") << "# header\n" << points_line << "\n";
  try {
    ReadSlamMap(dir);
    FAIL() << "no error for " << points_line;
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, line) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    EXPECT_NE(e.where().path.find("points.txt"), std::string::npos);
  }
}

TEST(SlamMapFile, BadPointsNameFileAndLine) {
  const fs::path dir = TempDir("bad");
  ExpectErrorAt(dir, "7 1 2 3 2 0 1 2 0 -1", 2, "observations need");
  ExpectErrorAt(dir, "7 1 2 3 1 5 1 2 0 -1", 2, "keyframes.txt does not list");
  ExpectErrorAt(dir, "7 1 2 3 1 0 1 2 9 -1", 2, "outside the pyramid");
  ExpectErrorAt(dir, "7 1 x 3 0", 2, "y");
  fs::remove_all(dir);
}

TEST(SlamMapFile, MissingOrForeignHeaderIsAnInputError) {
  const fs::path dir = TempDir("hdr");
  WriteSlamMap(dir, SmallMap());
  std::ofstream(dir / "map.json") << R"({"format": "something-else"})";
  EXPECT_THROW(ReadSlamMap(dir), InputError);
  fs::remove(dir / "map.json");
  EXPECT_THROW(ReadSlamMap(dir), InputError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rs
