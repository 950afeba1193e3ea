// The surface evaluator's inputs and the pair-density measure: binary PLY meshes read back (and
// refused with the file named when malformed), and real pairs without poses filling the grid.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "eval/surface/pair_density.h"
#include "eval/surface/surface_eval.h"
#include "formats/input_error.h"
#include "tests/support/test_data.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

fs::path WritePly(const std::string& name, const std::string& header, const std::string& body) {
  const fs::path p = fs::temp_directory_path() / (name + std::to_string(::getpid()) + ".ply");
  std::ofstream(p, std::ios::binary) << header << body;
  return p;
}

std::string Bytes(const void* p, size_t n) { return std::string(static_cast<const char*>(p), n); }

TEST(ReadPlyMesh, ReadsPositionsAndTrianglesPastOtherProperties) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  std::string body;
  const float v[3][3] = {{0, 0, 1}, {1, 0, 2}, {0, 1, 3}};
  for (const auto& p : v) body += Bytes(p, 12) + "abc";
  const int32_t f[3] = {0, 1, 2};
  body += std::string(1, char(3)) + Bytes(f, 12);
  const fs::path path = WritePly("rs_ply_ok", header, body);
  const TriangleMesh m = ReadPlyMesh(path);
  ASSERT_EQ(m.vertices.size(), 3u);
  EXPECT_DOUBLE_EQ(m.vertices[2].z(), 3.0);
  ASSERT_EQ(m.faces.size(), 1u);
  EXPECT_EQ(m.faces[0], Eigen::Vector3i(0, 1, 2));
  // Cut short in the face list: an error naming the file and the face.
  const fs::path cut = WritePly("rs_ply_cut", header, body.substr(0, body.size() - 4));
  try {
    ReadPlyMesh(cut);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(cut.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("face 0"), std::string::npos) << e.what();
  }
  // ASCII PLY is refused by name.
  const fs::path ascii = WritePly("rs_ply_ascii", "ply\nformat ascii 1.0\nend_header\n", "");
  EXPECT_THROW(ReadPlyMesh(ascii), InputError);
  for (const auto& p : {path, cut, ascii}) fs::remove(p);
}

// Fan 2021 model3: real asphalt close up, no poses. Every pair fills ≥ 99 % of the road cells
// visible in both views at the stage's 1 cm cell.
TEST(PairDensity, Fan2021PairsFillTheVisibleRoad) {
  const fs::path dir = test::DataRoot() / "pothole_recon_fan2021" / "model3";
  if (!fs::exists(dir / "calibration_rectified.yaml"))
    GTEST_SKIP() << "no pothole_recon_fan2021 data under " << dir << " (set ROADSURVEY_DATA)";
  const auto rows = EvaluatePairDensity(dir, {0.01});
  ASSERT_GE(rows.size(), 5u);
  for (const auto& r : rows) {
    EXPECT_GT(r.visible_cells, 9000) << r.left;  // about 1 m x 0.9 m of road at 1 cm
    EXPECT_GE(r.filled_fraction, 0.99) << r.left;
  }
}

}  // namespace
}  // namespace rs
