#include "stages/surface/grid_mesh.h"

#include <gtest/gtest.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <pcl/PolygonMesh.h>
#include <pcl/io/ply_io.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <tuple>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "formats/checked_file.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

constexpr double kX0 = 500000.0, kY0 = 5400000.0;  // the grid's north-west corner (UTM-like)
const Eigen::Vector3d kOffset(500000.0, 5400000.0, 100.0);

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "grid_mesh_test.XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// A whole height grid; blocks are cut from it.
struct Grid {
  cv::Mat height_m, colour;
  double cell = 0.01;

  HeightBlock Block(int r0, int c0, int rows, int cols) const {
    const cv::Rect roi(c0, r0, cols, rows);
    HeightBlock b;
    b.height_m = height_m(roi);
    if (!colour.empty()) b.colour = colour(roi);
    b.x_min = kX0 + c0 * cell;
    b.y_max = kY0 - r0 * cell;
    b.cell = cell;
    return b;
  }
  double X(int c) const { return kX0 + (c + 0.5) * cell - kOffset.x(); }
  double Y(int r) const { return kY0 - (r + 0.5) * cell - kOffset.y(); }
};

// Feeds `grid` as tiles of `tile` cells, each with the first row/column of its neighbours.
void AddTiled(const Grid& grid, int tile, GridMeshWriter* writer) {
  const int rows = grid.height_m.rows, cols = grid.height_m.cols;
  for (int r0 = 0; r0 + 1 < rows; r0 += tile) {
    for (int c0 = 0; c0 + 1 < cols; c0 += tile) {
      writer->AddBlock(grid.Block(r0, c0, std::min(tile + 1, rows - r0), std::min(tile + 1, cols - c0)));
    }
  }
}

// Our binary PLY, read independently of the writer.
struct PlyMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<uint8_t, 3>> rgb;
  std::vector<std::array<int32_t, 3>> faces;
};

PlyMesh ReadPly(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  int64_t nv = -1, nf = -1;
  while (std::getline(in, line) && line != "end_header") {
    if (line.rfind("element vertex ", 0) == 0) nv = std::stoll(line.substr(15));
    if (line.rfind("element face ", 0) == 0) nf = std::stoll(line.substr(13));
  }
  EXPECT_GE(nv, 0);
  EXPECT_GE(nf, 0);
  PlyMesh m;
  for (int64_t i = 0; i < nv; ++i) {
    char record[15];
    in.read(record, sizeof record);
    Eigen::Vector3f p;
    std::memcpy(p.data(), record, 12);
    m.positions.push_back(p);
    m.rgb.push_back({uint8_t(record[12]), uint8_t(record[13]), uint8_t(record[14])});
  }
  for (int64_t i = 0; i < nf; ++i) {
    char record[13];
    in.read(record, sizeof record);
    EXPECT_EQ(record[0], 3);
    std::array<int32_t, 3> f;
    std::memcpy(f.data(), record + 1, 12);
    for (int32_t v : f) EXPECT_TRUE(v >= 0 && v < nv);
    m.faces.push_back(f);
  }
  EXPECT_TRUE(in.good());
  EXPECT_EQ(in.peek(), EOF);
  return m;
}

// Finds the triangles over a point in xy through a uniform grid of buckets.
class TriangleIndex {
 public:
  TriangleIndex(const PlyMesh& m, double bucket_m) : m_(m), bucket_(bucket_m) {
    lo_ = Eigen::Vector2d::Constant(1e300);
    Eigen::Vector2d hi = Eigen::Vector2d::Constant(-1e300);
    for (const auto& p : m.positions) {
      lo_ = lo_.cwiseMin(p.head<2>().cast<double>());
      hi = hi.cwiseMax(p.head<2>().cast<double>());
    }
    nx_ = int((hi.x() - lo_.x()) / bucket_) + 1;
    ny_ = int((hi.y() - lo_.y()) / bucket_) + 1;
    buckets_.resize(size_t(nx_) * ny_);
    for (size_t t = 0; t < m.faces.size(); ++t) {
      Eigen::Vector2d a = Eigen::Vector2d::Constant(1e300), b = -a;
      for (int32_t v : m.faces[t]) {
        a = a.cwiseMin(m.positions[v].head<2>().cast<double>());
        b = b.cwiseMax(m.positions[v].head<2>().cast<double>());
      }
      for (int j = Cell(a.y(), lo_.y(), ny_); j <= Cell(b.y(), lo_.y(), ny_); ++j) {
        for (int i = Cell(a.x(), lo_.x(), nx_); i <= Cell(b.x(), lo_.x(), nx_); ++i) {
          buckets_[size_t(j) * nx_ + i].push_back(int(t));
        }
      }
    }
  }

  /// The height of every triangle over (x, y), its edges included.
  std::vector<double> HeightsAt(double x, double y) const {
    std::vector<double> heights;
    if (x < lo_.x() - 1e-6 || y < lo_.y() - 1e-6) return heights;
    const int i = Cell(x, lo_.x(), nx_), j = Cell(y, lo_.y(), ny_);
    for (int t : buckets_[size_t(j) * nx_ + i]) {
      Eigen::Vector3d p[3];
      for (int k = 0; k < 3; ++k) p[k] = m_.positions[m_.faces[t][k]].cast<double>();
      const double area2 = (p[1].x() - p[0].x()) * (p[2].y() - p[0].y()) - (p[2].x() - p[0].x()) * (p[1].y() - p[0].y());
      EXPECT_GT(area2, 0) << "triangle " << t << " is turned over in xy";
      double l[3];
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d& u = p[(k + 1) % 3];
        const Eigen::Vector3d& w = p[(k + 2) % 3];
        l[k] = ((u.x() - x) * (w.y() - y) - (w.x() - x) * (u.y() - y)) / area2;
      }
      if (l[0] >= -1e-6 && l[1] >= -1e-6 && l[2] >= -1e-6) {
        heights.push_back(l[0] * p[0].z() + l[1] * p[1].z() + l[2] * p[2].z());
      }
    }
    return heights;
  }

 private:
  int Cell(double v, double lo, int n) const { return std::clamp(int((v - lo) / bucket_), 0, n - 1); }

  const PlyMesh& m_;
  double bucket_;
  Eigen::Vector2d lo_;
  int nx_ = 0, ny_ = 0;
  std::vector<std::vector<int>> buckets_;
};

// A coordinate as the files hold it. Through a volatile: GCC 12.2's SLP vectorizer drops paired
// double -> float -> double round trips.
double AsWritten(double v) {
  volatile float f = float(v);
  return f;
}

// True for the cells that the triangulation uses (a 2x2 group with three or four heights).
cv::Mat MeshedCells(const cv::Mat& height_m) {
  cv::Mat meshed(height_m.size(), CV_8U, cv::Scalar(0));
  for (int r = 0; r + 1 < height_m.rows; ++r) {
    for (int c = 0; c + 1 < height_m.cols; ++c) {
      int n = 0;
      for (int k = 0; k < 4; ++k) n += std::isfinite(height_m.at<float>(r + k / 2, c + k % 2));
      if (n < 3) continue;
      for (int k = 0; k < 4; ++k) {
        if (std::isfinite(height_m.at<float>(r + k / 2, c + k % 2))) meshed.at<uint8_t>(r + k / 2, c + k % 2) = 1;
      }
    }
  }
  return meshed;
}

// The largest vertical distance of a grid vertex to the mesh over it (-1 when one is not covered).
double MaxVerticalError(const Grid& grid, const TriangleIndex& index) {
  const cv::Mat meshed = MeshedCells(grid.height_m);
  double worst = 0;
  for (int r = 0; r < grid.height_m.rows; ++r) {
    for (int c = 0; c < grid.height_m.cols; ++c) {
      if (!meshed.at<uint8_t>(r, c)) continue;
      // The vertex as written: float, relative to the offset.
      const double x = AsWritten(grid.X(c)), y = AsWritten(grid.Y(r));
      const double z = AsWritten(double(grid.height_m.at<float>(r, c)) - kOffset.z());
      const std::vector<double> heights = index.HeightsAt(x, y);
      if (heights.empty()) return -1;
      for (double h : heights) worst = std::max(worst, std::abs(h - z));
    }
  }
  return worst;
}

// A road: 2.5 % crossfall, 1 % gradient, a parabolic bowl and a steep-walled pothole, both
// 0.05 m deep and 0.4 m across, and Gaussian noise of `noise_m`.
Grid SyntheticRoad(int rows, int cols, double noise_m) {
  Grid g;
  g.height_m.create(rows, cols, CV_32F);
  g.colour.create(rows, cols, CV_8UC3);
  cv::RNG rng(7);
  const double bowl_x = 1.2, bowl_y = -1.0, steep_x = 3.6, steep_y = -1.6;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double x = (c + 0.5) * g.cell, y = -(r + 0.5) * g.cell;
      double z = 100.4 + 0.01 * x + 0.025 * y;
      const double d_bowl = std::hypot(x - bowl_x, y - bowl_y);
      if (d_bowl < 0.2) z -= 0.05 * (1 - (d_bowl / 0.2) * (d_bowl / 0.2));
      const double d_steep = std::hypot(x - steep_x, y - steep_y);
      if (d_steep < 0.2) z -= 0.05 * std::min(1.0, (0.2 - d_steep) / 0.05);  // flat bottom, 45 degree walls
      g.height_m.at<float>(r, c) = float(z + rng.gaussian(noise_m));
      const uint8_t grey = uint8_t(90 + (r * 7 + c * 3) % 60);
      g.colour.at<cv::Vec3b>(r, c) = cv::Vec3b(grey, uint8_t(grey + 10), uint8_t(grey + 20));
    }
  }
  return g;
}

void Report(const char* name, const GridMeshStats& s, double measured_error_m) {
  std::cout << name << ": faces " << s.grid_faces << " -> " << s.faces << " ("
            << 100.0 * double(s.faces) / double(s.grid_faces) << " %), vertices " << s.grid_vertices << " -> "
            << s.vertices << ", max vertical error " << s.max_height_error_m * 1e3 << " mm (measured on the PLY "
            << measured_error_m * 1e3 << " mm), " << s.mesh_s / double(s.pieces) * 1e3 << " ms per piece of "
            << s.pieces << "\n";
}

TEST(GridMesh, FlatPlaneCollapses) {
  TempDir dir;
  Grid g;
  g.cell = 0.02;
  g.height_m.create(150, 200, CV_32F);
  for (int r = 0; r < 150; ++r) {
    for (int c = 0; c < 200; ++c) g.height_m.at<float>(r, c) = float(100.3 + 0.03 * (c * g.cell) - 0.02 * (r * g.cell));
  }
  GridMeshWriter writer(dir.path() / "plane.ply", dir.path() / "plane.obj", kOffset);
  writer.AddBlock(g.Block(0, 0, 150, 200));
  const GridMeshStats s = writer.Finish();

  const PlyMesh mesh = ReadPly(dir.path() / "plane.ply");
  const double error = MaxVerticalError(g, TriangleIndex(mesh, 0.1));
  Report("flat plane", s, error);
  EXPECT_EQ(s.grid_faces, 2 * 199 * 149);
  EXPECT_LT(double(s.faces), 0.02 * double(s.grid_faces));
  EXPECT_GE(error, 0) << "a grid vertex is not covered";
  EXPECT_LE(error, GridMeshOptions{}.max_height_error_m + 1e-6);
  EXPECT_LE(s.max_height_error_m, GridMeshOptions{}.max_height_error_m);
}

TEST(GridMesh, PotholesStayWithinVerticalBound) {
  TempDir dir;
  const Grid g = SyntheticRoad(300, 512, 0.0005);
  GridMeshOptions options;
  GridMeshWriter writer(dir.path() / "road.ply", dir.path() / "road.obj", kOffset, options);
  const HeightBlock whole = g.Block(0, 0, g.height_m.rows, g.height_m.cols);
  writer.AddBlock(whole);  // meshed in pieces of at most 257 x 257 cells
  const GridMeshStats s = writer.Finish();
  EXPECT_EQ(s.pieces, 4);

  const PlyMesh mesh = ReadPly(dir.path() / "road.ply");
  ASSERT_EQ(int64_t(mesh.faces.size()), s.faces);
  const TriangleIndex index(mesh, 0.05);
  const double error = MaxVerticalError(g, index);
  Report("noisy road with potholes", s, error);
  EXPECT_GE(error, 0) << "a grid vertex is not covered";
  EXPECT_LE(error, options.max_height_error_m + 1e-6);
  EXPECT_LE(s.max_height_error_m, options.max_height_error_m);
  EXPECT_LT(s.faces, s.grid_faces);
  // The bottoms keep their depth: 0.05 m below the road, noise and the bound aside.
  for (const auto& [x, y] : {std::pair{1.2, -1.0}, std::pair{3.6, -1.6}}) {
    const std::vector<double> h = index.HeightsAt(kX0 + x - kOffset.x(), kY0 + y - kOffset.y());
    ASSERT_FALSE(h.empty());
    EXPECT_NEAR(h[0] + kOffset.z(), 100.4 + 0.01 * x + 0.025 * y - 0.05, options.max_height_error_m + 0.002);
  }
}

TEST(GridMesh, AdjacentBlocksMeetAndHolesStayHoles) {
  TempDir dir;
  Grid g = SyntheticRoad(100, 180, 0.0005);
  // A hole across the seam (column 90) and one inside the first block.
  for (const auto& [rc, cc, radius] : {std::tuple{50, 90, 8}, std::tuple{30, 40, 5}}) {
    for (int r = rc - radius; r <= rc + radius; ++r) {
      for (int c = cc - radius; c <= cc + radius; ++c) {
        if (std::hypot(r - rc, c - cc) <= radius) g.height_m.at<float>(r, c) = std::nanf("");
      }
    }
  }
  GridMeshWriter writer(dir.path() / "two.ply", dir.path() / "two.obj", kOffset);
  writer.AddBlock(g.Block(0, 0, 100, 91));
  writer.AddBlock(g.Block(0, 90, 100, 90));
  const GridMeshStats s = writer.Finish();
  EXPECT_EQ(s.pieces, 2);

  const PlyMesh mesh = ReadPly(dir.path() / "two.ply");
  const TriangleIndex index(mesh, 0.05);
  const double error = MaxVerticalError(g, index);
  Report("two blocks with holes", s, error);
  EXPECT_GE(error, 0);
  EXPECT_LE(error, GridMeshOptions{}.max_height_error_m + 1e-6);

  // Every point of a group with four heights is covered, up to 10 um from its edges (float
  // rounding aside, so a crack along the seam would show); a group without heights is not.
  const double fractions[] = {0.001, 0.25, 0.5, 0.75, 0.999};
  int uncovered = 0, filled = 0, holes = 0;
  for (int r = 0; r + 1 < g.height_m.rows; ++r) {
    for (int c = 0; c + 1 < g.height_m.cols; ++c) {
      int n = 0;
      for (int k = 0; k < 4; ++k) n += std::isfinite(g.height_m.at<float>(r + k / 2, c + k % 2));
      if (n == 0) {
        ++holes;
        filled += !index.HeightsAt(0.5 * (g.X(c) + g.X(c + 1)), 0.5 * (g.Y(r) + g.Y(r + 1))).empty();
      } else if (n == 4) {
        for (double fx : fractions) {
          for (double fy : fractions) uncovered += index.HeightsAt(g.X(c) + fx * g.cell, g.Y(r) - fy * g.cell).empty();
        }
      }
    }
  }
  EXPECT_GT(holes, 100);
  EXPECT_EQ(uncovered, 0);
  EXPECT_EQ(filled, 0);
}

TEST(GridMesh, OutputsLoadInPclAndOpenMesh) {
  TempDir dir;
  const Grid g = SyntheticRoad(120, 140, 0.0005);
  const fs::path ply = dir.path() / "mesh.ply", obj = dir.path() / "mesh.obj";
  GridMeshWriter writer(ply, obj, kOffset);
  AddTiled(g, 64, &writer);
  const GridMeshStats s = writer.Finish();
  EXPECT_FALSE(fs::exists(ply.string() + ".vertices.tmp"));
  EXPECT_FALSE(fs::exists(ply.string() + ".faces.tmp"));
  EXPECT_FALSE(fs::exists(obj.string() + ".tmp"));

  // Colours are the grid's, BGR turned into RGB.
  const PlyMesh mine = ReadPly(ply);
  ASSERT_EQ(int64_t(mine.positions.size()), s.vertices);
  for (size_t i = 0; i < mine.positions.size(); ++i) {
    const int c = int(std::lround((mine.positions[i].x() + kOffset.x() - kX0) / g.cell - 0.5));
    const int r = int(std::lround((kY0 - mine.positions[i].y() - kOffset.y()) / g.cell - 0.5));
    const cv::Vec3b bgr = g.colour.at<cv::Vec3b>(r, c);
    ASSERT_EQ(mine.rgb[i], (std::array<uint8_t, 3>{bgr[2], bgr[1], bgr[0]})) << "vertex " << i;
  }

  pcl::PolygonMesh pcl_mesh;
  ASSERT_EQ(pcl::io::loadPLYFile(ply.string(), pcl_mesh), 0);
  EXPECT_EQ(int64_t(pcl_mesh.cloud.width) * pcl_mesh.cloud.height, s.vertices);
  EXPECT_EQ(int64_t(pcl_mesh.polygons.size()), s.faces);
  bool has_colour = false;
  for (const auto& field : pcl_mesh.cloud.fields) has_colour |= field.name == "rgb" || field.name == "rgba";
  EXPECT_TRUE(has_colour);

  using Mesh = OpenMesh::TriMesh_ArrayKernelT<>;
  for (const fs::path& path : {ply, obj}) {
    Mesh om;
    om.request_vertex_colors();
    OpenMesh::IO::Options opt = OpenMesh::IO::Options::VertexColor;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(om, path.string(), opt)) << path;
    EXPECT_EQ(int64_t(om.n_vertices()), s.vertices) << path;
    EXPECT_EQ(int64_t(om.n_faces()), s.faces) << path;
    ASSERT_TRUE(opt.check(OpenMesh::IO::Options::VertexColor)) << path;
    const auto colour = om.color(Mesh::VertexHandle(0));
    EXPECT_EQ(colour[0], mine.rgb[0][0]) << path;
    EXPECT_EQ(colour[2], mine.rgb[0][2]) << path;
    const auto p = om.point(Mesh::VertexHandle(0));
    EXPECT_NEAR(p[0], mine.positions[0].x(), 1e-5) << path;
  }
}

TEST(GridMesh, MissingFolderThrowsWriteError) {
  TempDir dir;
  const fs::path missing = dir.path() / "missing" / "mesh.ply";
  try {
    GridMeshWriter writer(missing, dir.path() / "mesh.obj", kOffset);
    FAIL() << "no WriteError";
  } catch (const WriteError& e) {
    EXPECT_NE(e.path().string().find(missing.string()), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_empty(dir.path())) << "a temporary was left behind";
  EXPECT_THROW(GridMeshWriter(dir.path() / "a.ply", dir.path() / "a.obj", kOffset, GridMeshOptions{-1}),
               std::invalid_argument);
}

TEST(GridMesh, UnfinishedWriterLeavesNothing) {
  TempDir dir;
  {
    GridMeshWriter writer(dir.path() / "a.ply", dir.path() / "a.obj", kOffset);
    const Grid g = SyntheticRoad(20, 20, 0);
    writer.AddBlock(g.Block(0, 0, 20, 20));
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

}  // namespace
}  // namespace rs
