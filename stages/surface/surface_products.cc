#include "stages/surface/surface_products.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "stages/surface/grid_mesh.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

GeoTiffGeoreference GeorefOf(const SurfaceGrid& g, const RasterCrs& crs) {
  GeoTiffGeoreference r;
  r.x_min = g.x_min;
  r.y_max = g.y_max;
  r.cell = g.cell;
  r.epsg = crs.epsg;
  r.vertical_epsg = crs.vertical_epsg;
  r.citation = crs.citation;
  return r;
}

std::unique_ptr<GeoTiffWriter> Open(const fs::path& path, const SurfaceGrid& g, int type, const RasterCrs& crs,
                                    double nodata, const std::string& description) {
  GeoTiffOptions o;
  o.tile_size = g.tile;
  o.nodata = nodata;
  o.description = description;
  return std::make_unique<GeoTiffWriter>(path, g.cols, g.rows, type, GeorefOf(g, crs), o);
}

}  // namespace

SurfaceRasters::SurfaceRasters(const fs::path& dir, const SurfaceGrid& grid, const RasterCrs& crs) : grid_(grid) {
  dsm_ = Open(dir / "dsm.tif", grid, CV_32FC1, crs, kDsmNodata, "surface height, m, " + crs.heights);
  sigma_ = Open(dir / "dsm_sigma.tif", grid, CV_32FC1, crs, kDsmNodata, "1-sigma uncertainty of dsm.tif, m");
  count_ = Open(dir / "dsm_count.tif", grid, CV_16UC1, crs, 0, "views fused into each cell of dsm.tif");
  ortho_ = Open(dir / "ortho.tif", grid, CV_8UC3, crs, 0, "orthophoto: each cell's nearest, most certain view");
}

void SurfaceRasters::WriteTile(int tile, const FusedTile& t) {
  const int tc = tile % grid_.tiles_across(), tr = tile / grid_.tiles_across();
  const int w = std::min(grid_.tile, grid_.cols - tc * grid_.tile);
  const int h = std::min(grid_.tile, grid_.rows - tr * grid_.tile);
  const cv::Rect roi(0, 0, w, h);
  cv::Mat height = t.height_m(roi).clone(), sigma = t.sigma_m(roi).clone(), colour = t.colour(roi).clone();
  // No height: NaN (cv::compare is not NaN-aware on every code path). Filled holes have a height
  // and a count of 0.
  cv::Mat empty(h, w, CV_8U);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) empty.at<uint8_t>(r, c) = std::isfinite(height.at<float>(r, c)) ? 0 : 255;
  height.setTo(kDsmNodata, empty);
  sigma.setTo(kDsmNodata, empty);
  colour.setTo(cv::Scalar::all(0), empty);
  dsm_->WriteTile(tc, tr, height);
  sigma_->WriteTile(tc, tr, sigma);
  count_->WriteTile(tc, tr, t.count(roi));
  ortho_->WriteTile(tc, tr, colour);
  const int filled = w * h - cv::countNonZero(empty);
  totals_.cells_interpolated += filled - cv::countNonZero(t.count(roi));
  ++totals_.tiles;
  totals_.cells_filled += filled;
  if (filled > 0) {
    totals_.sigma_sum_m += cv::sum(sigma.setTo(0, empty))[0];
    totals_.tiles_written.push_back(tile);
  }
}

void SurfaceRasters::Finish() {
  dsm_->Finish();
  sigma_->Finish();
  count_->Finish();
  ortho_->Finish();
}

MeshSummary WriteSurfaceMesh(const fs::path& dir, const SurfaceGrid& grid, const std::vector<int>& tiles,
                             const Eigen::Vector3d& offset, double max_height_error_m) {
  GridMeshOptions mo;
  mo.max_height_error_m = max_height_error_m;
  GridMeshWriter mesh(dir / "mesh.ply", dir / "mesh.obj", offset, mo);
  GeoTiffReader dsm(dir / "dsm.tif"), ortho(dir / "ortho.tif");
  std::vector<int> sorted = tiles;
  std::sort(sorted.begin(), sorted.end());
  // Batches of blocks, meshed in parallel: memory stays a few blocks whatever the survey's length.
  constexpr size_t kBatch = 8;
  std::vector<HeightBlock> batch;
  for (size_t i = 0; i < sorted.size(); ++i) {
    const int tile = sorted[i];
    const int tc = tile % grid.tiles_across(), tr = tile / grid.tiles_across();
    const int x = tc * grid.tile, y = tr * grid.tile;
    // One extra column and row (the neighbours' first), so adjacent blocks share their seam.
    const int w = std::min(grid.tile + 1, grid.cols - x), h = std::min(grid.tile + 1, grid.rows - y);
    HeightBlock b;
    b.height_m = dsm.Window(x, y, w, h);
    b.height_m.setTo(std::numeric_limits<float>::quiet_NaN(), b.height_m == static_cast<float>(kDsmNodata));
    b.colour = ortho.Window(x, y, w, h);
    b.x_min = grid.x_min + x * grid.cell;
    b.y_max = grid.y_max - y * grid.cell;
    b.cell = grid.cell;
    batch.push_back(std::move(b));
    if (batch.size() == kBatch || i + 1 == sorted.size()) {
      mesh.AddBlocks(batch);
      batch.clear();
    }
  }
  const GridMeshStats s = mesh.Finish();
  MeshSummary m;
  m.grid_vertices = s.grid_vertices;
  m.grid_faces = s.grid_faces;
  m.vertices = s.vertices;
  m.faces = s.faces;
  m.max_height_error_m = s.max_height_error_m;
  m.offset = offset;
  return m;
}

}  // namespace rs
