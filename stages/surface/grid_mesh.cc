#include "stages/surface/grid_mesh.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <system_error>

#include <opencv2/core.hpp>
#include <tbb/parallel_for.h>

#include "stages/surface/grid_mesh_block.h"
#include "stages/surface/grid_mesh_file.h"

namespace rs {
namespace {

// An OpenMesh mesh of at most this many cells a side is held at a time.
constexpr int kMaxPieceCells = 257;

void CheckBlock(const HeightBlock& b) {
  if (b.height_m.type() != CV_32F) throw std::invalid_argument("HeightBlock.height_m must be CV_32F");
  if (!(std::isfinite(b.cell) && b.cell > 0)) {
    throw std::invalid_argument(fmt::format("HeightBlock.cell = {} violates cell > 0", b.cell));
  }
  if (b.colour.empty()) return;
  if (b.colour.type() != CV_8UC3 && b.colour.type() != CV_8UC1) {
    throw std::invalid_argument("HeightBlock.colour must be CV_8UC3 (BGR), CV_8UC1 or empty");
  }
  if (b.colour.size() != b.height_m.size()) {
    throw std::invalid_argument(fmt::format("HeightBlock.colour is {}x{}, height_m {}x{}: they must match",
                                            b.colour.cols, b.colour.rows, b.height_m.cols, b.height_m.rows));
  }
}

// Rows [r0, r0 + rows) and columns [c0, c0 + cols) of `b`, placed where they lie.
HeightBlock Piece(const HeightBlock& b, int r0, int c0, int rows, int cols) {
  const cv::Rect roi(c0, r0, cols, rows);
  HeightBlock p;
  p.height_m = b.height_m(roi);
  if (!b.colour.empty()) p.colour = b.colour(roi);
  p.x_min = b.x_min + c0 * b.cell;
  p.y_max = b.y_max - r0 * b.cell;
  p.cell = b.cell;
  return p;
}

std::string PlyHeader(const GridMeshStats& s, const Eigen::Vector3d& offset) {
  return fmt::format(
      "ply\nformat binary_little_endian 1.0\n"
      "comment roadsurvey road-surface mesh; coordinates are CRS metres minus offset {:.3f} {:.3f} {:.3f}\n"
      "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
      offset.x(), offset.y(), offset.z(), s.vertices, s.faces);
}

std::string ObjHeader(const GridMeshStats& s, const Eigen::Vector3d& offset) {
  return fmt::format(
      "# roadsurvey road-surface mesh: {} vertices, {} faces\n"
      "# coordinates are CRS metres minus offset {:.3f} {:.3f} {:.3f}; vertex colours r g b in [0, 1]\n",
      s.vertices, s.faces, offset.x(), offset.y(), offset.z());
}

}  // namespace

void GridMeshOptions::Check() const {
  if (!(std::isfinite(max_height_error_m) && max_height_error_m > 0)) {
    throw std::invalid_argument(
        fmt::format("grid_mesh.max_height_error_m = {} violates max_height_error_m > 0", max_height_error_m));
  }
}

struct GridMeshWriter::Impl {
  Impl(std::filesystem::path ply, std::filesystem::path obj, const Eigen::Vector3d& off, const GridMeshOptions& opt)
      : ply_path(std::move(ply)),
        obj_path(std::move(obj)),
        offset(off),
        options(opt),
        vertices(ply_path.string() + ".vertices.tmp"),
        faces(ply_path.string() + ".faces.tmp"),
        obj_body(obj_path.string() + ".tmp") {}

  ~Impl() {
    std::error_code ignored;
    for (const AppendFile* f : {&vertices, &faces, &obj_body}) std::filesystem::remove(f->path(), ignored);
    if (outputs_started && !finished) {
      std::filesystem::remove(ply_path, ignored);
      std::filesystem::remove(obj_path, ignored);
    }
  }

  /// Writes a meshed piece after the ones before it.
  void AppendMesh(const BlockMesh& mesh);

  const std::filesystem::path ply_path, obj_path;
  const Eigen::Vector3d offset;
  const GridMeshOptions options;
  AppendFile vertices, faces, obj_body;  // the PLY's two bodies and the OBJ's, in block order
  GridMeshStats stats;
  bool outputs_started = false, finished = false;
};

void GridMeshWriter::Impl::AppendMesh(const BlockMesh& mesh) {
  const int64_t base = stats.vertices;  // this piece's first vertex in the whole mesh
  if (base + int64_t(mesh.positions.size()) > std::numeric_limits<int32_t>::max()) {
    throw std::length_error("grid mesh: more vertices than the PLY's int indices can address");
  }
  std::string bytes;
  fmt::memory_buffer text;
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    const auto& rgb = mesh.rgb[i];
    char record[15];
    std::memcpy(record, p.data(), 12);
    std::memcpy(record + 12, rgb.data(), 3);
    bytes.append(record, sizeof record);
    fmt::format_to(std::back_inserter(text), "v {} {} {} {:.4f} {:.4f} {:.4f}\n", p.x(), p.y(), p.z(),
                   rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
  }
  vertices.Append(bytes);
  bytes.clear();
  for (const auto& f : mesh.faces) {
    char record[13];
    record[0] = 3;
    for (int k = 0; k < 3; ++k) {
      const int32_t index = int32_t(base + f[k]);
      std::memcpy(record + 1 + 4 * k, &index, 4);
    }
    bytes.append(record, sizeof record);
    fmt::format_to(std::back_inserter(text), "f {} {} {}\n", base + f[0] + 1, base + f[1] + 1, base + f[2] + 1);
  }
  faces.Append(bytes);
  obj_body.Append(std::string_view(text.data(), text.size()));

  stats.grid_vertices += mesh.grid_vertices;
  stats.grid_faces += mesh.grid_faces;
  stats.vertices += int64_t(mesh.positions.size());
  stats.faces += int64_t(mesh.faces.size());
  stats.max_height_error_m = std::max(stats.max_height_error_m, mesh.max_height_error_m);
  ++stats.pieces;
}

GridMeshWriter::GridMeshWriter(std::filesystem::path ply_path, std::filesystem::path obj_path, Eigen::Vector3d offset,
                               GridMeshOptions options) {
  options.Check();
  impl_ = std::make_unique<Impl>(std::move(ply_path), std::move(obj_path), offset, options);
}

GridMeshWriter::~GridMeshWriter() = default;

void GridMeshWriter::AddBlock(const HeightBlock& block) { AddBlocks({block}); }

void GridMeshWriter::AddBlocks(const std::vector<HeightBlock>& blocks) {
  if (impl_->finished) throw std::logic_error("GridMeshWriter::AddBlocks after Finish");
  std::vector<HeightBlock> pieces;
  for (const HeightBlock& block : blocks) {
    CheckBlock(block);
    const int rows = block.height_m.rows, cols = block.height_m.cols;
    // Pieces overlap by one row and column, as blocks do, so their locked edges meet.
    for (int r0 = 0; r0 + 1 < rows || r0 == 0; r0 += kMaxPieceCells - 1)
      for (int c0 = 0; c0 + 1 < cols || c0 == 0; c0 += kMaxPieceCells - 1) {
        const int piece_rows = std::min(kMaxPieceCells, rows - r0), piece_cols = std::min(kMaxPieceCells, cols - c0);
        if (piece_rows >= 2 && piece_cols >= 2) pieces.push_back(Piece(block, r0, c0, piece_rows, piece_cols));
      }
  }
  // Pieces are independent: meshed in parallel, written in order (the output does not depend on
  // the number of threads).
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<BlockMesh> meshes(pieces.size());
  tbb::parallel_for(size_t(0), pieces.size(),
                    [&](size_t i) { meshes[i] = MeshHeightBlock(pieces[i], impl_->offset, impl_->options); });
  impl_->stats.mesh_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const BlockMesh& m : meshes) impl_->AppendMesh(m);
}

GridMeshStats GridMeshWriter::Finish() {
  Impl& m = *impl_;
  if (m.finished) throw std::logic_error("GridMeshWriter::Finish called twice");
  m.vertices.Close();
  m.faces.Close();
  m.obj_body.Close();
  m.outputs_started = true;

  AppendFile ply(m.ply_path);
  ply.Append(PlyHeader(m.stats, m.offset));
  ply.AppendContentsOf(m.vertices.path());
  ply.AppendContentsOf(m.faces.path());
  ply.Close();

  AppendFile obj(m.obj_path);
  obj.Append(ObjHeader(m.stats, m.offset));
  obj.AppendContentsOf(m.obj_body.path());
  obj.Close();

  m.finished = true;
  std::error_code ignored;
  for (const AppendFile* f : {&m.vertices, &m.faces, &m.obj_body}) std::filesystem::remove(f->path(), ignored);
  return m.stats;
}

}  // namespace rs
