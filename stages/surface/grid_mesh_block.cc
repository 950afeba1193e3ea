#include "stages/surface/grid_mesh_block.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModEdgeLengthT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "stages/surface/grid_mesh_vertical_error.h"

namespace rs {
namespace {

// The decimation works in lattice units: x = column, y = -row (north up), z = height / cell.
// Grid points are then exact small integers in xy, so three of them in a line make a triangle of
// exactly zero area, never a float-rounded sliver that hides a vertical step; and the space is
// the metric one scaled, so quadric priorities are unchanged.
struct GridMeshTraits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  VertexAttributes(OpenMesh::Attributes::Status);
  HalfedgeAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::PrevHalfedge);
  EdgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status);
};
using GridTriMesh = OpenMesh::TriMesh_ArrayKernelT<GridMeshTraits>;
using VertexHandle = GridTriMesh::VertexHandle;

// Builds the triangulated grid; vertices are created only for cells that some triangle uses.
class GridTriangulator {
 public:
  GridTriangulator(const HeightBlock& block, GridTriMesh* mesh)
      : block_(block), mesh_(*mesh), handles_(block.height_m.total()) {}

  void Run() {
    const cv::Mat& h = block_.height_m;
    for (int r = 0; r + 1 < h.rows; ++r) {
      for (int c = 0; c + 1 < h.cols; ++c) AddGroup(r, c);
    }
  }

 private:
  // The 2x2 group with top-left cell (r, c); corners counter-clockwise seen from above (north up):
  // top-left, bottom-left, bottom-right, top-right.
  void AddGroup(int r, int c) {
    const int rows[4] = {r, r + 1, r + 1, r}, cols[4] = {c, c, c + 1, c + 1};
    float z[4];
    int valid[4], n = 0;
    for (int i = 0; i < 4; ++i) {
      z[i] = block_.height_m.at<float>(rows[i], cols[i]);
      if (std::isfinite(z[i])) valid[n++] = i;
    }
    auto corner = [&](int i) { return Vertex(rows[i], cols[i]); };
    if (n == 3) {
      AddTriangle(corner(valid[0]), corner(valid[1]), corner(valid[2]));
    } else if (n == 4) {
      // The diagonal between the closer heights follows a ridge or a rut rather than cutting it.
      if (std::abs(z[0] - z[2]) <= std::abs(z[1] - z[3])) {
        AddTriangle(corner(0), corner(1), corner(2));
        AddTriangle(corner(0), corner(2), corner(3));
      } else {
        AddTriangle(corner(0), corner(1), corner(3));
        AddTriangle(corner(1), corner(2), corner(3));
      }
    }
  }

  VertexHandle Vertex(int r, int c) {
    VertexHandle& v = handles_[size_t(r) * block_.height_m.cols + c];
    if (!v.is_valid()) {
      const double z = double(block_.height_m.at<float>(r, c)) / block_.cell;
      v = mesh_.add_vertex(GridTriMesh::Point(c, -r, z));
    }
    return v;
  }

// A triangle that would make a vertex or an edge non-manifold (diagonal holes) gets vertices of
  // its own; they lie on a boundary, so they are locked and the surface stays closed in xy.
  void AddTriangle(VertexHandle a, VertexHandle b, VertexHandle c) {
    if (mesh_.add_face(a, b, c).is_valid()) return;
    VertexHandle copies[3];
    const VertexHandle corners[3] = {a, b, c};
    for (int i = 0; i < 3; ++i) copies[i] = mesh_.add_vertex(mesh_.point(corners[i]));
    mesh_.add_face(copies[0], copies[1], copies[2]);
  }

  const HeightBlock& block_;
  GridTriMesh& mesh_;
  std::vector<VertexHandle> handles_;
};

constexpr double kMaxEdgeCells = 16;

// Collapses interior vertices, cheapest quadric error first, while the vertical bound (in lattice
// units) holds; returns the largest vertical error left, in lattice units.
double Decimate(GridTriMesh* mesh, double max_height_error) {
  for (auto v : mesh->vertices()) {
    if (mesh->is_boundary(v)) mesh->status(v).set_locked(true);
  }
  OpenMesh::Decimater::DecimaterT<GridTriMesh> decimater(*mesh);
  OpenMesh::Decimater::ModQuadricT<GridTriMesh>::Handle quadric;
  ModVerticalErrorT<GridTriMesh>::Handle vertical;
  decimater.add(quadric);
  decimater.module(quadric).unset_max_err();  // priority only; the vertical module decides
  decimater.add(vertical);
  decimater.module(vertical).set_tolerance(max_height_error);
  // Edges longer than kMaxEdgeCells are not collapsed: faces stay small enough that checking the
  // grid points under them stays cheap (the check's cost grows with the points per face), and a
  // flat road still loses ~99 % of its faces.
  OpenMesh::Decimater::ModEdgeLengthT<GridTriMesh>::Handle edge_length;
  decimater.add(edge_length);
  decimater.module(edge_length).set_edge_length(kMaxEdgeCells);
  decimater.module(edge_length).set_binary(true);
  if (!decimater.initialize()) throw std::logic_error("grid mesh: the decimater rejected its modules");
  decimater.decimate(0);
  return decimater.module(vertical).MaxVerticalError();
}

// A vertex as written: CRS minus offset, rounded to float; its colour as RGB.
void AppendVertex(const HeightBlock& b, const Eigen::Vector3d& offset, int r, int c, BlockMesh* out) {
  const double x = b.x_min + (c + 0.5) * b.cell - offset.x();
  const double y = b.y_max - (r + 0.5) * b.cell - offset.y();
  const double z = double(b.height_m.at<float>(r, c)) - offset.z();
  out->positions.emplace_back(float(x), float(y), float(z));
  if (b.colour.empty()) {
    out->rgb.push_back({128, 128, 128});
  } else if (b.colour.type() == CV_8UC1) {
    const uint8_t g = b.colour.at<uint8_t>(r, c);
    out->rgb.push_back({g, g, g});
  } else {
    const cv::Vec3b bgr = b.colour.at<cv::Vec3b>(r, c);
    out->rgb.push_back({bgr[2], bgr[1], bgr[0]});
  }
}

}  // namespace

BlockMesh MeshHeightBlock(const HeightBlock& block, const Eigen::Vector3d& offset, const GridMeshOptions& options) {
  GridTriMesh mesh;
  GridTriangulator(block, &mesh).Run();
  BlockMesh out;
  out.grid_vertices = int64_t(mesh.n_vertices());
  out.grid_faces = int64_t(mesh.n_faces());
  if (mesh.n_faces() == 0) return out;
  out.max_height_error_m = Decimate(&mesh, options.max_height_error_m / block.cell) * block.cell;
  for (auto v : mesh.vertices()) {
    if (mesh.is_isolated(v)) mesh.delete_vertex(v, false);  // corners of a face that got copies
  }
  mesh.garbage_collection();

  out.positions.reserve(mesh.n_vertices());
  out.rgb.reserve(mesh.n_vertices());
  for (auto v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    AppendVertex(block, offset, int(-p[1]), int(p[0]), &out);
  }
  out.faces.reserve(mesh.n_faces());
  for (auto f : mesh.faces()) {
    std::array<int32_t, 3> face{};
    int i = 0;
    for (auto v : mesh.fv_range(f)) face[i++] = v.idx();
    out.faces.push_back(face);
  }
  return out;
}

}  // namespace rs
