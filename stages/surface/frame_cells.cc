#include "stages/surface/frame_cells.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace rs {
namespace {

struct PixelSample {
  int64_t cell;
  float h, s;
  uint8_t bgr[3];
};

}  // namespace

bool PlacePixel(const FrameView& v, int u, int row, Eigen::Vector3d* p, double* sigma_h) {
  const float d = v.disparity_px.at<float>(row, u);
  if (!(d > 0)) return false;
  if (!v.use.empty() && v.use.at<uint8_t>(row, u) == 0) return false;
  const double bf = v.camera.bf();
  const double z = bf / d;
  if (v.max_range_m > 0 && z > v.max_range_m) return false;
  const Eigen::Vector3d ray((u - v.camera.cx_px) / v.camera.f_px, (row - v.camera.cy_px) / v.camera.f_px, 1.0);
  const Eigen::Matrix3d A = v.crs_from_camera.leftCols<3>();
  *p = A * (ray * z) + v.crs_from_camera.col(3);
  // A depth error moves the point along its ray: the height changes by the ray's vertical
  // component per metre of depth.
  const double sigma_z = z * z * v.sigma_disparity_px / bf;
  *sigma_h = std::max(std::abs((A * ray).z()) * sigma_z, 1e-4);
  return true;
}

std::vector<CellSample> FrameCellObservations(const FrameView& v, const SurfaceGrid& grid) {
  const int rows = v.disparity_px.rows, cols = v.disparity_px.cols;
  std::vector<std::vector<PixelSample>> per_row(rows);
  tbb::parallel_for(0, rows, [&](int r) {
    auto& out = per_row[r];
    out.reserve(cols);
    const cv::Vec3b* c = v.colour.ptr<cv::Vec3b>(r);
    for (int u = 0; u < cols; ++u) {
      Eigen::Vector3d p;
      double s;
      if (!PlacePixel(v, u, r, &p, &s)) continue;
      const int64_t gc = grid.ColOf(p.x()), gr = grid.RowOf(p.y());
      if (!grid.Contains(gc, gr)) continue;
      out.push_back({gr * grid.cols + gc, static_cast<float>(p.z()), static_cast<float>(s), {c[u][0], c[u][1], c[u][2]}});
    }
  });
  std::vector<PixelSample> all;
  size_t n = 0;
  for (const auto& r : per_row) n += r.size();
  all.reserve(n);
  for (auto& r : per_row) all.insert(all.end(), r.begin(), r.end());
  std::sort(all.begin(), all.end(),
            [](const PixelSample& a, const PixelSample& b) { return a.cell != b.cell ? a.cell < b.cell : a.h < b.h; });
  std::vector<CellSample> cells;
  for (size_t i = 0; i < all.size();) {
    size_t j = i;
    int sum[3] = {0, 0, 0};
    std::vector<float> sig;
    for (; j < all.size() && all[j].cell == all[i].cell; ++j) {
      for (int k = 0; k < 3; ++k) sum[k] += all[j].bgr[k];
      sig.push_back(all[j].s);
    }
    const size_t m = j - i;
    std::nth_element(sig.begin(), sig.begin() + m / 2, sig.end());
    CellSample cs;
    cs.cell = all[i].cell;
    cs.obs.height_m = all[i + m / 2].h;  // sorted by height within the cell: the median
    cs.obs.sigma_m = sig[m / 2];
    for (int k = 0; k < 3; ++k) cs.obs.bgr[k] = static_cast<uint8_t>((sum[k] + int(m) / 2) / int(m));
    cells.push_back(cs);
    i = j;
  }
  return cells;
}

std::vector<Eigen::Vector2d> FrameFootprint(const FrameView& v, int stride) {
  std::vector<Eigen::Vector2d> pts;
  for (int r = 0; r < v.disparity_px.rows; r += stride)
    for (int u = 0; u < v.disparity_px.cols; u += stride) {
      Eigen::Vector3d p;
      double s;
      if (PlacePixel(v, u, r, &p, &s)) pts.emplace_back(p.x(), p.y());
    }
  return pts;
}

double MedianPixelFootprintM(const FrameView& v, int stride) {
  std::vector<double> g;
  for (int r = 0; r < v.disparity_px.rows; r += stride)
    for (int u = 0; u < v.disparity_px.cols; u += stride) {
      Eigen::Vector3d p;
      double s;
      if (PlacePixel(v, u, r, &p, &s)) g.push_back(v.camera.bf() / v.disparity_px.at<float>(r, u) / v.camera.f_px);
    }
  if (g.empty()) return 0;
  std::nth_element(g.begin(), g.begin() + g.size() / 2, g.end());
  return g[g.size() / 2];
}

}  // namespace rs
