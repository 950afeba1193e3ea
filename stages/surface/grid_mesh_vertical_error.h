#pragma once
// An OpenMesh decimater module that bounds the VERTICAL error of a height-field mesh. In the style
// of ModHausdorffT, every removed vertex is kept in the list of the face it projects into (in xy);
// a collapse is legal only while each of them stays within the tolerance of that face's height at
// its (x, y). ModHausdorffT bounds the 3-D distance, which on a steep pothole wall is far smaller
// than the height difference.
//
// The mesh stays a height field: a collapse that turns a face of the one-ring over (or flat) in xy
// is illegal, so with the boundary locked the one-ring after a collapse covers exactly the xy area
// it covered before, and every removed point projects into exactly one face (or onto an edge
// shared by faces that agree there). The orientation test is exact when x and y are small
// integers (grid_mesh_block.cc meshes in lattice units), so no float-thin sliver passes for a face.

#include <OpenMesh/Tools/Decimater/ModBaseT.hh>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace rs {

/// Binary module: legal collapses keep every removed vertex within `tolerance()` (in the mesh's
/// z units) vertically of the mesh.
template <class MeshT>
class ModVerticalErrorT : public OpenMesh::Decimater::ModBaseT<MeshT> {
 public:
  DECIMATING_MODULE(ModVerticalErrorT, MeshT, VerticalError);
  using Point = typename Mesh::Point;
  using FaceHandle = typename Mesh::FaceHandle;
  using VertexHandle = typename Mesh::VertexHandle;

  explicit ModVerticalErrorT(MeshT& mesh) : Base(mesh, true), mesh_(Base::mesh()) { mesh_.add_property(points_); }
  ~ModVerticalErrorT() override { mesh_.remove_property(points_); }

  double tolerance() const { return tolerance_; }
  void set_tolerance(double tolerance) { tolerance_ = tolerance; }

  void initialize() override {
    for (auto f : mesh_.faces()) mesh_.property(points_, f).clear();
    ++version_;
  }

  float collapse_priority(const CollapseInfo& ci) override {
    GatherStar(ci.v0);
    SelectRing(ci);
    mesh_.set_point(ci.v0, ci.p1);  // simulate the collapse
    bool ok = BuildTriangles();
    mesh_.set_point(ci.v0, ci.p0);
    for (size_t i = 0; ok && i < moved_.size(); ++i) {
      const int t = ContainingTriangle(moved_[i], Hint(i));
      ok = t >= 0 && std::abs(tris_[t].HeightError(moved_[i])) <= tolerance_;
    }
    return ok ? float(Base::LEGAL_COLLAPSE) : float(Base::ILLEGAL_COLLAPSE);
  }

  // The faces that survive keep their handles through the collapse; only their points move.
  void preprocess_collapse(const CollapseInfo& ci) override {
    GatherStar(ci.v0);
    SelectRing(ci);
    for (FaceHandle f : star_) mesh_.property(points_, f).clear();
  }

  void postprocess_collapse(const CollapseInfo& ci) override {
    ++version_;
    BuildTriangles();
    for (size_t i = 0; i < moved_.size(); ++i) {
      int t = ContainingTriangle(moved_[i], Hint(i));
      if (t < 0) t = NearestTriangle(moved_[i]);  // rounding only: the legality test found a face
      if (t >= 0) mesh_.property(points_, ring_[t]).push_back(moved_[i]);
    }
  }

  /// The largest height difference between a removed vertex and the face it projects into.
  double MaxVerticalError() const {
    double worst = 0;
    for (auto f : mesh_.faces()) {
      if (mesh_.status(f).deleted()) continue;
      const Triangle tri = MakeTriangle(f);
      for (const Point& p : mesh_.property(points_, f)) worst = std::max(worst, std::abs(tri.HeightError(p)));
    }
    return worst;
  }

 private:
  // A face projected to xy: barycentric coordinate i is e[i] . (x, y, 1).
  struct Triangle {
    double e[3][3];
    double z[3];
    double area2 = 0;  // twice the signed xy area, > 0 for a counter-clockwise face

    void Barycentric(const Point& p, double l[3]) const {
      for (int i = 0; i < 3; ++i) l[i] = e[i][0] * p[0] + e[i][1] * p[1] + e[i][2];
    }
    double HeightError(const Point& p) const {
      double l[3];
      Barycentric(p, l);
      return p[2] - (l[0] * z[0] + l[1] * z[1] + l[2] * z[2]);
    }
  };

  // Barycentric slack for points on a shared edge; faces agree there, so either may take them.
  static constexpr double kInsideSlack = 1e-9;

  Triangle MakeTriangle(FaceHandle f) const {
    double x[3], y[3];
    Triangle t;
    int i = 0;
    for (auto v : mesh_.fv_range(f)) {
      const Point& q = mesh_.point(v);
      x[i] = q[0], y[i] = q[1], t.z[i] = q[2];
      ++i;
    }
    t.area2 = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
    const double inv = t.area2 != 0 ? 1 / t.area2 : 0;
    for (int k = 0; k < 3; ++k) {
      const int j = (k + 1) % 3, m = (k + 2) % 3;
      t.e[k][0] = (y[j] - y[m]) * inv;
      t.e[k][1] = (x[m] - x[j]) * inv;
      t.e[k][2] = (x[j] * y[m] - x[m] * y[j]) * inv;
    }
    return t;
  }

  // The faces around v0 (star_) and every point that a collapse of v0 may move: those of the
  // star's faces and v0 itself (moved_, with the star face each lay in or -1). The decimater asks
  // for every halfedge out of v0 in turn, so this is kept until the mesh changes.
  void GatherStar(VertexHandle v0) {
    if (v0 == star_vertex_ && version_ == star_version_) return;
    star_vertex_ = v0;
    star_version_ = version_;
    star_.clear();
    moved_.clear();
    star_of_point_.clear();
    for (auto f : mesh_.vf_range(v0)) {
      const auto& pts = mesh_.property(points_, f);
      moved_.insert(moved_.end(), pts.begin(), pts.end());
      star_of_point_.insert(star_of_point_.end(), pts.size(), int(star_.size()));
      star_.push_back(f);
    }
    moved_.push_back(mesh_.point(v0));
    star_of_point_.push_back(-1);
  }

  // The faces that remain after the collapse (ring_): the star less the two that vanish.
  void SelectRing(const CollapseInfo& ci) {
    ring_.clear();
    ring_of_star_.clear();
    for (FaceHandle f : star_) {
      const bool kept = f != ci.fl && f != ci.fr;
      ring_of_star_.push_back(kept ? int(ring_.size()) : -1);
      if (kept) ring_.push_back(f);
    }
  }

  // Most points stay in their face, so it is tried first.
  int Hint(size_t i) const { return star_of_point_[i] < 0 ? -1 : ring_of_star_[star_of_point_[i]]; }

  // False when a face of the ring is turned over or flat in xy.
  bool BuildTriangles() {
    tris_.clear();
    bool ok = true;
    for (FaceHandle f : ring_) {
      tris_.push_back(MakeTriangle(f));
      if (!(tris_.back().area2 > 0)) ok = false;
    }
    return ok;
  }

  bool Contains(int t, const Point& p) const {
    double l[3];
    tris_[t].Barycentric(p, l);
    return l[0] >= -kInsideSlack && l[1] >= -kInsideSlack && l[2] >= -kInsideSlack;
  }

  int ContainingTriangle(const Point& p, int hint) const {
    if (hint >= 0 && Contains(hint, p)) return hint;
    for (int t = 0; t < int(tris_.size()); ++t) {
      if (t != hint && Contains(t, p)) return t;
    }
    return -1;
  }

  int NearestTriangle(const Point& p) const {
    int best = -1;
    double best_min = -1e300;
    for (int t = 0; t < int(tris_.size()); ++t) {
      double l[3];
      tris_[t].Barycentric(p, l);
      const double m = std::min({l[0], l[1], l[2]});
      if (m > best_min) best_min = m, best = t;
    }
    return best;
  }

  Mesh& mesh_;
  double tolerance_ = 0;
  OpenMesh::FPropHandleT<std::vector<Point>> points_;
  int64_t version_ = 0;  // counts collapses: a gathered star is current while it is unchanged
  VertexHandle star_vertex_;
  int64_t star_version_ = -1;
  std::vector<FaceHandle> star_, ring_;
  std::vector<Point> moved_;
  std::vector<int> star_of_point_, ring_of_star_;
  std::vector<Triangle> tris_;
};

}  // namespace rs
