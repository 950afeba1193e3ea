#include "eval/surface/pair_density.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "formats/input_error.h"
#include "formats/rectified_stereo.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/image_io.h"
#include "stages/disparity/disparity.h"
#include "stages/surface/frame_cells.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

// Road plane of the dense points (camera frame): least squares, twice trimmed at 3 robust σ.
// Returns the transform camera -> plane frame (x, y on the plane, z along its normal, up toward the camera).
Eigen::Matrix<double, 3, 4> PlaneFrame(const DisparityResult& r, const RectifiedStereo& g) {
  std::vector<Eigen::Vector3d> pts;
  for (int v = 0; v < r.disparity.rows; v += 4)
    for (int u = 0; u < r.disparity.cols; u += 4)
      if (const float d = r.disparity.at<float>(v, u); d > 0) {
        const double z = g.bf() / d;
        pts.emplace_back((u - g.cx_px) * z / g.f_px, (v - g.cy_px) * z / g.f_px, z);
      }
  if (pts.size() < 100) throw std::runtime_error("too few valid pixels for a road plane");
  Eigen::Vector3d n(0, 0, 1), c(0, 0, 0);
  std::vector<Eigen::Vector3d> use = pts;
  for (int pass = 0; pass < 3; ++pass) {
    c = Eigen::Vector3d::Zero();
    for (const auto& p : use) c += p;
    c /= static_cast<double>(use.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& p : use) cov += (p - c) * (p - c).transpose();
    n = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0);
    std::vector<double> res;
    for (const auto& p : pts) res.push_back(std::abs(n.dot(p - c)));
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = 3 * 1.4826 * sorted[sorted.size() / 2];
    use.clear();
    for (size_t i = 0; i < pts.size(); ++i)
      if (res[i] <= limit) use.push_back(pts[i]);
  }
  if (n.dot(c) > 0) n = -n;  // up = toward the camera
  const Eigen::Vector3d e1 = (Eigen::Vector3d::UnitX() - n * n.x()).normalized();
  const Eigen::Vector3d e2 = n.cross(e1);
  Eigen::Matrix3d R;
  R.row(0) = e1;
  R.row(1) = e2;
  R.row(2) = n;
  Eigen::Matrix<double, 3, 4> M;
  M.leftCols<3>() = R;
  M.col(3) = -R * c;
  return M;
}

}  // namespace

std::vector<PairDensityRow> EvaluatePairDensity(const fs::path& dir, const std::vector<double>& cells_m) {
  const fs::path calib_path = dir / "calibration_rectified.yaml";
  const StereoCalibration calib = ReadCalibrationYaml(calib_path);
  const RectifiedStereo g = RectifiedStereoOf(calib);
  std::vector<PairDensityRow> rows;
  for (int i = 1;; ++i) {
    const fs::path lp = dir / "left images" / fmt::format("L{}.png", i);
    const fs::path rp = dir / "right images" / fmt::format("R{}.png", i);
    if (!fs::exists(lp)) break;
    const cv::Mat left = LoadGray8(lp), right = LoadGray8(rp);
    DisparityParams params;
    params.camera_focal_px = calib.left.fx;
    const DisparityResult r = ComputeDisparity(left, right, params);
    FrameView v;
    v.camera = g;
    v.disparity_px = r.disparity;
    v.colour = cv::Mat(left.size(), CV_8UC3, cv::Scalar::all(0));
    v.crs_from_camera = PlaneFrame(r, g);
    const Eigen::Matrix3d A = v.crs_from_camera.leftCols<3>();
    const Eigen::Vector3d b = v.crs_from_camera.col(3);
    // Visible road: pixels whose road-model point lies inside the right image, on the plane.
    std::vector<Eigen::Vector2d> visible;
    int64_t visible_px = 0, valid_px = 0;
    for (int y = 0; y < left.rows; ++y)
      for (int x = 0; x < left.cols; ++x) {
        const double d_road = r.road.At(x, y);
        if (!(d_road > 0) || x - d_road < 0) continue;
        ++visible_px;
        valid_px += r.disparity.at<float>(y, x) > 0;
        const Eigen::Vector3d ray((x - g.cx_px) / g.f_px, (y - g.cy_px) / g.f_px, 1.0);
        // ray ∩ plane z = 0 in the plane frame: (A ray) t + b has zero height.
        const double t = -b.z() / (A.row(2).dot(ray));
        if (t > 0) visible.emplace_back((A * ray * t + b).head<2>());
      }
    double x0 = INFINITY, y1 = -INFINITY, x1 = -INFINITY, y0 = INFINITY;
    for (const auto& p : visible) {
      x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x());
      y0 = std::min(y0, p.y()), y1 = std::max(y1, p.y());
    }
    for (double cell : cells_m) {
      SurfaceGrid grid;
      grid.cell = cell;
      grid.x_min = std::floor(x0 / cell) * cell - 10 * cell;
      grid.y_max = std::ceil(y1 / cell) * cell + 10 * cell;
      grid.cols = static_cast<int>(std::ceil((x1 - grid.x_min) / cell)) + 10;
      grid.rows = static_cast<int>(std::ceil((grid.y_max - y0) / cell)) + 10;
      std::unordered_set<int64_t> vis, filled;
      for (const auto& p : visible) vis.insert(grid.RowOf(p.y()) * grid.cols + grid.ColOf(p.x()));
      for (const CellSample& s : FrameCellObservations(v, grid)) filled.insert(s.cell);
      PairDensityRow row;
      row.left = lp.filename().string();
      row.cell_m = cell;
      row.pixel_m = MedianPixelFootprintM(v, 4);
      row.visible_cells = static_cast<int64_t>(vis.size());
      for (int64_t c : vis) row.filled_cells += filled.count(c);
      row.filled_fraction = row.visible_cells ? double(row.filled_cells) / row.visible_cells : 0;
      row.pixel_density = visible_px ? double(valid_px) / visible_px : 0;
      rows.push_back(row);
    }
  }
  if (rows.empty()) throw InputError(InputLocation::File((dir / "left images").string()), "no pair L1.png / R1.png");
  return rows;
}

std::string PairDensityTable(const std::vector<PairDensityRow>& rows) {
  std::string s = "| pair | cell, mm | pixel, mm | visible road cells | filled | filled % | pixel density % |\n"
                  "|---|---|---|---|---|---|---|\n";
  for (const auto& r : rows)
    s += fmt::format("| {} | {:.0f} | {:.2f} | {} | {} | {:.2f} | {:.2f} |\n", r.left, r.cell_m * 1000, r.pixel_m * 1000,
                     r.visible_cells, r.filled_cells, 100 * r.filled_fraction, 100 * r.pixel_density);
  return s;
}

}  // namespace rs
