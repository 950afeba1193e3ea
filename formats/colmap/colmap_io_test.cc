#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "formats/colmap/colmap_io.h"
#include "formats/input_error.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

// Two cameras, three images, two points: every field set to a value that is not a default.
ColmapModel SmallModel() {
  ColmapModel m;
  m.cameras = {{1, "PINHOLE", 640, 480, {500.25, 501.5, 320.5, 240.75}},
               {2, "OPENCV", 1241, 376, {718.856, 718.856, 607.1928, 185.2157, 0.01, -0.002, 1e-4, -3e-5}}};
  for (uint32_t i = 0; i < 3; ++i) {
    ColmapImage im;
    im.id = 10 + i;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.1 * (i + 1), Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.3 * i, -1.0 / 3.0, 2.0 + i);
    im.SetPose(T);
    im.camera_id = i == 2 ? 2 : 1;
    im.name = "left/00000" + std::to_string(i) + ".png";
    m.images.push_back(im);
  }
  m.images[0].points2d = {{10.125, 20.5, 100}, {1.0 / 3.0, 2.0 / 7.0, kColmapNoPoint3D}, {30.0, 40.0, 101}};
  m.images[1].points2d = {{11.0, 21.0, 100}};
  m.images[2].points2d = {{5.5, 6.5, 101}, {7.5, 8.5, 100}};
  m.points = {{100, {1.0 / 3.0, -2.5, 10.0}, {255, 0, 7}, 0.75, {{10, 0}, {11, 0}, {12, 1}}},
              {101, {0.1, 0.2, 12.0}, {1, 2, 3}, -1, {{10, 2}, {12, 0}}}};
  return m;
}

void ExpectSameModel(const ColmapModel& a, const ColmapModel& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(a.cameras[i].id, b.cameras[i].id);
    EXPECT_EQ(a.cameras[i].model, b.cameras[i].model);
    EXPECT_EQ(a.cameras[i].width, b.cameras[i].width);
    EXPECT_EQ(a.cameras[i].height, b.cameras[i].height);
    EXPECT_EQ(a.cameras[i].params, b.cameras[i].params);  // 17 digits: exact
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (size_t i = 0; i < a.images.size(); ++i) {
    const auto &x = a.images[i], &y = b.images[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.camera_id, y.camera_id);
    EXPECT_EQ(x.q_cam_world.coeffs(), y.q_cam_world.coeffs());
    EXPECT_EQ(x.t_cam_world, y.t_cam_world);
    ASSERT_EQ(x.points2d.size(), y.points2d.size());
    for (size_t k = 0; k < x.points2d.size(); ++k) {
      EXPECT_EQ(x.points2d[k].x, y.points2d[k].x);
      EXPECT_EQ(x.points2d[k].y, y.points2d[k].y);
      EXPECT_EQ(x.points2d[k].point3d_id, y.points2d[k].point3d_id);
    }
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].id, b.points[i].id);
    EXPECT_EQ(a.points[i].xyz, b.points[i].xyz);
    EXPECT_EQ(a.points[i].rgb, b.points[i].rgb);
    EXPECT_EQ(a.points[i].error, b.points[i].error);
    EXPECT_EQ(a.points[i].track, b.points[i].track);
  }
}

fs::path TempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("colmap_io_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

TEST(ColmapIo, TextRoundTripIsExact) {
  const fs::path dir = TempDir("text");
  WriteColmapModel(dir, SmallModel(), ColmapFormat::kText);
  ExpectSameModel(SmallModel(), ReadColmapModel(dir));
  fs::remove_all(dir);
}

TEST(ColmapIo, BinaryRoundTripIsExact) {
  const fs::path dir = TempDir("bin");
  WriteColmapModel(dir, SmallModel(), ColmapFormat::kBinary);
  ExpectSameModel(SmallModel(), ReadColmapModel(dir));
  fs::remove_all(dir);
}

TEST(ColmapIo, BinaryLayoutMatchesColmap) {
  // cameras.bin of one PINHOLE camera: count u64, id u32, model i32, width u64, height u64, 4 doubles.
  const std::string b = ColmapCamerasBinary({{7, "PINHOLE", 640, 480, {1, 2, 3, 4}}});
  ASSERT_EQ(b.size(), 8u + 4 + 4 + 8 + 8 + 4 * 8);
  EXPECT_EQ(b[0], 1);
  EXPECT_EQ(b[8], 7);
  EXPECT_EQ(b[12], 1);  // PINHOLE's model id
}

TEST(ColmapIo, RigConfigRoundTrip) {
  ColmapRig rig;
  rig.ref_camera_id = 1;
  rig.cameras.push_back({1, "left/", Eigen::Isometry3d::Identity()});
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(-0.54, 0, 0);
  rig.cameras.push_back({2, "right/", T});
  std::istringstream in(ColmapRigConfigJson({rig}));
  const auto back = ReadColmapRigConfig(in, "rig.json");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].ref_camera_id, 1u);
  ASSERT_EQ(back[0].cameras.size(), 2u);
  EXPECT_EQ(back[0].cameras[1].image_prefix, "right/");
  EXPECT_TRUE(back[0].cameras[1].T_cam_rig.isApprox(T, 1e-15));
}

// Each bad text input fails naming the file and the line (and column where one field is at fault).
TEST(ColmapIo, BadTextNamesFileAndLine) {
  struct Case {
    std::string text;
    std::string where;
    std::string message;
  };
  const std::vector<Case> cameras = {
      {"# c\n1 PINHOLE 640 480 1 2 3\n", "cameras.txt:2", "PINHOLE takes 4 parameters, got 3"},
      {"1 NOPE 640 480 1 2 3 4\n", "cameras.txt:1:3", "unknown camera model 'NOPE'"},
      {"1 PINHOLE 640 x 1 2 3 4\n", "cameras.txt:1:15", "HEIGHT 'x' is not an integer"},
      {"1 PINHOLE 640 480 1 nan 3 4\n", "cameras.txt:1:21", "not a finite number"},
  };
  for (const auto& c : cameras) {
    std::istringstream in(c.text);
    try {
      ReadColmapCamerasText(in, "cameras.txt");
      ADD_FAILURE() << c.text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().ToString(), c.where) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << e.what();
    }
  }
  std::istringstream images("1 1 0 0 0 0 0 0 1 a.png\n1 2 3\n2 2 0 0 0 0 0 0 1 b.png\n");
  try {
    ReadColmapImagesText(images, "images.txt");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().ToString(), "images.txt:3:3") << e.what();  // quaternion (2,0,0,0)
  }
  std::istringstream points("1 0 0 0 1 2 3 0.5 4\n");
  EXPECT_THROW(ReadColmapPointsText(points, "points3D.txt"), InputError);
}

// Truncated or oversized binary input fails at a byte offset, without allocating the claimed count.
TEST(ColmapIo, BadBinaryNamesByteOffset) {
  const std::string good = ColmapImagesBinary(SmallModel().images);
  for (size_t cut : {size_t(3), size_t(20), good.size() - 1}) {
    try {
      ReadColmapImagesBinary(std::string_view(good).substr(0, cut), "images.bin");
      ADD_FAILURE() << cut;
    } catch (const InputError& e) {
      EXPECT_GE(e.where().byte_offset, 0);
      EXPECT_LE(e.where().byte_offset, static_cast<int64_t>(cut));
    }
  }
  std::string huge = ColmapPointsBinary({});
  huge[7] = 0x7f;  // 2^62-ish points in 8 bytes
  try {
    ReadColmapPointsBinary(huge, "points3D.bin");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().ToString(), "points3D.bin @ byte 0");
  }
  EXPECT_THROW(ReadColmapCamerasBinary(good + "x", "cameras.bin"), InputError);
}

TEST(ColmapIo, InconsistentModelIsAnError) {
  const fs::path dir = TempDir("inconsistent");
  ColmapModel m = SmallModel();
  m.points[0].track.pop_back();  // image 12's 2D point 1 still names point 100
  WriteColmapModel(dir, m, ColmapFormat::kText);
  try {
    ReadColmapModel(dir);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("image 12 2D point 1 names 3D point 100"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rs
