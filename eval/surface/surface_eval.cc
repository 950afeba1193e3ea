#include "eval/surface/surface_eval.h"

#include <fmt/format.h>

#include <GeographicLib/LocalCartesian.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "eval/damage_map/damage_map_eval.h"
#include "formats/geo/cameras_csv.h"
#include "formats/geo/georeference_file.h"
#include "formats/geo/geotiff.h"
#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "formats/trajectory/tum_trajectory.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr double kHoleLimitM = 0.05;
constexpr double kImagedCloseM = 0.25;  // gaps narrower than this between fused cells lie inside the imaged road
constexpr double kShiftSearchM = 0.10;  // planimetric search radius
constexpr double kStepM = 0.05;         // a truth step this high between cells is a kerb face
constexpr double kLocalSigmaM = 1.5;    // reach of a camera's placement error in TruthAsPlaced

struct Raster {
  cv::Mat z;  // CV_32F, NaN empty
  double x_min = 0, y_max = 0, cell = 0;
};

// 255 where a CV_32F value is finite (cv::compare is not NaN-aware on every code path).
cv::Mat FiniteMask(const cv::Mat& m) {
  cv::Mat out(m.size(), CV_8U);
  for (int r = 0; r < m.rows; ++r)
    for (int c = 0; c < m.cols; ++c) out.at<uint8_t>(r, c) = std::isfinite(m.at<float>(r, c)) ? 255 : 0;
  return out;
}

// Barycentric rasterisation of the truth triangles (CRS coordinates, moved by `shift`) at the cell centres.
cv::Mat RasterizeMesh(const std::vector<Eigen::Vector3d>& v, const std::vector<Eigen::Vector3i>& faces,
                      const Raster& grid, const Eigen::Vector3d& shift) {
  cv::Mat z(grid.z.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (const Eigen::Vector3i& f : faces) {
    const Eigen::Vector3d a = v[f[0]] + shift, b = v[f[1]] + shift, c = v[f[2]] + shift;
    const double cx0 = std::min({a.x(), b.x(), c.x()}), cx1 = std::max({a.x(), b.x(), c.x()});
    const double cy0 = std::min({a.y(), b.y(), c.y()}), cy1 = std::max({a.y(), b.y(), c.y()});
    const int c0 = std::max(0, int(std::ceil((cx0 - grid.x_min) / grid.cell - 0.5)));
    const int c1 = std::min(z.cols - 1, int(std::floor((cx1 - grid.x_min) / grid.cell - 0.5)));
    const int r0 = std::max(0, int(std::ceil((grid.y_max - cy1) / grid.cell - 0.5)));
    const int r1 = std::min(z.rows - 1, int(std::floor((grid.y_max - cy0) / grid.cell - 0.5)));
    const double det = (b.y() - c.y()) * (a.x() - c.x()) + (c.x() - b.x()) * (a.y() - c.y());
    if (std::abs(det) < 1e-12) continue;
    for (int r = r0; r <= r1; ++r)
      for (int col = c0; col <= c1; ++col) {
        const double x = grid.x_min + (col + 0.5) * grid.cell, y = grid.y_max - (r + 0.5) * grid.cell;
        const double l1 = ((b.y() - c.y()) * (x - c.x()) + (c.x() - b.x()) * (y - c.y())) / det;
        const double l2 = ((c.y() - a.y()) * (x - c.x()) + (a.x() - c.x()) * (y - c.y())) / det;
        const double l3 = 1 - l1 - l2;
        if (l1 < -1e-9 || l2 < -1e-9 || l3 < -1e-9) continue;
        z.at<float>(r, col) = static_cast<float>(l1 * a.z() + l2 * b.z() + l3 * c.z());
      }
  }
  return z;
}

HeightErrors Compare(const cv::Mat& ours, const cv::Mat& truth, const cv::Mat& where) {
  std::vector<double> e;
  for (int r = 0; r < ours.rows; ++r)
    for (int c = 0; c < ours.cols; ++c) {
      if (!where.empty() && where.at<uint8_t>(r, c) == 0) continue;
      const float a = ours.at<float>(r, c), b = truth.at<float>(r, c);
      if (std::isfinite(a) && std::isfinite(b)) e.push_back(double(a) - b);
    }
  HeightErrors h;
  h.cells = static_cast<int64_t>(e.size());
  if (e.empty()) return h;
  double s = 0, s2 = 0;
  for (double x : e) s += x, s2 += x * x;
  h.mean_m = s / e.size();
  h.rmse_m = std::sqrt(s2 / e.size());
  for (double& x : e) x = std::abs(x);
  std::sort(e.begin(), e.end());
  h.p95_abs_m = e[std::min(e.size() - 1, size_t(0.95 * e.size()))];
  h.median_abs_m = e[e.size() / 2];
  h.within_5mm = double(std::upper_bound(e.begin(), e.end(), 0.005) - e.begin()) / e.size();
  h.max_abs_m = e.back();
  return h;
}

// The horizontal shift (ours − truth, m) minimising the mean-removed height difference: the
// DSM's planimetric offset, located by the relief (potholes, crown, edges); parabolic sub-cell.
Eigen::Vector2d PlanimetricOffset(const cv::Mat& ours, const cv::Mat& truth, double cell) {
  const int R = static_cast<int>(std::ceil(kShiftSearchM / cell));
  cv::Mat cost(2 * R + 1, 2 * R + 1, CV_64F, cv::Scalar(INFINITY));
  for (int dy = -R; dy <= R; ++dy)
    for (int dx = -R; dx <= R; ++dx) {
      double s = 0, s2 = 0;
      int64_t n = 0;
      for (int r = std::max(0, dy); r < std::min(ours.rows, truth.rows + dy); ++r) {
        const float* a = ours.ptr<float>(r);
        const float* b = truth.ptr<float>(r - dy);
        for (int c = std::max(0, dx); c < std::min(ours.cols, truth.cols + dx); ++c) {
          const double d = double(a[c]) - b[c - dx];
          if (std::isfinite(d)) s += d, s2 += d * d, ++n;
        }
      }
      if (n > 100) cost.at<double>(dy + R, dx + R) = s2 / n - (s / n) * (s / n);
    }
  cv::Point best;
  cv::minMaxLoc(cost, nullptr, nullptr, &best, nullptr);
  const auto refine = [](double m, double c0, double p) {
    const double den = m - 2 * c0 + p;
    return (std::isfinite(den) && den > 0) ? 0.5 * (m - p) / den : 0.0;
  };
  double fx = best.x, fy = best.y;
  if (best.x > 0 && best.x < 2 * R)
    fx += refine(cost.at<double>(best.y, best.x - 1), cost.at<double>(best.y, best.x),
                 cost.at<double>(best.y, best.x + 1));
  if (best.y > 0 && best.y < 2 * R)
    fy += refine(cost.at<double>(best.y - 1, best.x), cost.at<double>(best.y, best.x),
                 cost.at<double>(best.y + 1, best.x));
  // Content moved right (+col) is +x; moved down (+row) is −y.
  return {(fx - R) * cell, -(fy - R) * cell};
}

// The carriageway of the truth surface: the largest region of truth cells connected without a
// step (kerb face) of more than kStepM between neighbours, kerb faces and a 2-cell margin beside
// them left out (there a planimetric offset of a cell changes the height by the kerb's height).
cv::Mat Carriageway(const cv::Mat& truth) {
  cv::Mat ok = FiniteMask(truth);
  cv::Mat step(truth.size(), CV_8U, cv::Scalar(0));
  for (int r = 0; r + 1 < truth.rows; ++r)
    for (int c = 0; c + 1 < truth.cols; ++c) {
      const float h = truth.at<float>(r, c), e = truth.at<float>(r, c + 1), s = truth.at<float>(r + 1, c);
      if (std::abs(h - e) > kStepM) step.at<uint8_t>(r, c) = step.at<uint8_t>(r, c + 1) = 255;
      if (std::abs(h - s) > kStepM) step.at<uint8_t>(r, c) = step.at<uint8_t>(r + 1, c) = 255;
    }
  cv::dilate(step, step, cv::getStructuringElement(cv::MORPH_RECT, {5, 5}));
  ok.setTo(0, step);
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(ok, labels, stats, centroids, 4);
  int best = 0;
  for (int i = 1; i < n; ++i)
    if (best == 0 || stats.at<int>(i, cv::CC_STAT_AREA) > stats.at<int>(best, cv::CC_STAT_AREA)) best = i;
  return best > 0 ? cv::Mat(labels == best) : cv::Mat(truth.size(), CV_8U, cv::Scalar(0));
}

// Holes inside the imaged road: truth road cells within the closed footprint of the fused cells
// that the DSM leaves empty, enclosed by filled cells; the widest hole's width.
void MeasureHoles(const cv::Mat& ours, const cv::Mat& road, double cell, const Eigen::Vector2d& origin,
                  SurfaceEvaluation* e) {
  const cv::Mat filled = FiniteMask(ours);
  const int k = 2 * static_cast<int>(std::ceil(kImagedCloseM / cell)) + 1;
  cv::Mat imaged;
  cv::morphologyEx(filled, imaged, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_ELLIPSE, {k, k}));
  const cv::Mat inside = imaged & road;
  const cv::Mat holes = inside & ~filled;
  e->road_cells = cv::countNonZero(inside);
  e->filled_fraction = e->road_cells ? 1.0 - double(cv::countNonZero(holes)) / e->road_cells : 0;
  // A hole's size is its width: twice the largest distance from inside it to a filled cell (a
  // one-cell sliver along a seam is 1 cell wide however long it runs).
  cv::Mat dist;
  cv::distanceTransform(holes, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(holes, labels, stats, centroids, 8);
  std::vector<double> width(n, 0);
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c)
      if (const int l = labels.at<int>(r, c); l > 0) width[l] = std::max(width[l], 2.0 * dist.at<float>(r, c) * cell);
  // A notch at the carriageway's edge (next to a kerb, where the DSM stops a few cells early) is not
  // a hole inside the road: only regions enclosed by filled cells count.
  cv::Mat outside = ~inside, touches;
  cv::dilate(outside, touches, cv::Mat());
  std::vector<char> at_edge(n, 0);
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c)
      if (const int l = labels.at<int>(r, c); l > 0 && touches.at<uint8_t>(r, c)) at_edge[l] = 1;
  for (int i = 1; i < n; ++i) {
    if (at_edge[i]) continue;
    e->largest_hole_m = std::max(e->largest_hole_m, width[i]);
    if (width[i] <= kHoleLimitM) continue;
    ++e->holes_over_5cm;
    const cv::Point2d c(centroids.at<double>(i, 0), centroids.at<double>(i, 1));
    e->holes.push_back({origin.x() + (c.x + 0.5) * cell, origin.y() - (c.y + 0.5) * cell, width[i]});
  }
}

struct CameraError {
  Eigen::Vector3d position, error;  // CRS; ours − truth
};

// Our cameras (cameras.csv, visual rows) against the truth poses, in the CRS.
std::vector<CameraError> CameraErrorsCrs(const fs::path& cameras_csv, const fs::path& truth_tum,
                                         const GeographicLib::LocalCartesian& truth_enu, const OutputCrs& crs) {
  const Trajectory truth = ReadTumTrajectory(truth_tum);
  std::vector<CameraError> out;
  for (const CameraRow& r : ReadCamerasCsv(cameras_csv)) {
    if (r.status != "visual" || !r.crs) continue;
    if (r.frame < 0 || r.frame >= static_cast<int64_t>(truth.poses.size())) continue;
    const Eigen::Vector3d t = truth.poses[r.frame].T_world_frame.translation();
    Geodetic g;
    truth_enu.Reverse(t.x(), t.y(), t.z(), g.lat_deg, g.lon_deg, g.h_ellipsoid_m);
    out.push_back({*r.crs, *r.crs - crs.Forward(g)});
  }
  return out;
}

// The truth as our cameras placed it: at each cell, the truth surface moved by the placement error
// of the cameras around it (Gaussian weights over horizontal distance, kLocalSigmaM; the error
// varies slowly along a trajectory), evaluated on a coarse grid and sampled bilinearly.
cv::Mat TruthAsPlaced(const cv::Mat& truth, const Raster& grid, const std::vector<CameraError>& cams) {
  constexpr double kCoarseM = 0.25;
  const int step = std::max(1, static_cast<int>(std::round(kCoarseM / grid.cell)));
  const int crows = truth.rows / step + 2, ccols = truth.cols / step + 2;
  cv::Mat field(crows, ccols, CV_64FC3);
  for (int r = 0; r < crows; ++r)
    for (int c = 0; c < ccols; ++c) {
      const double x = grid.x_min + c * step * grid.cell, y = grid.y_max - r * step * grid.cell;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double w = 0;
      for (const CameraError& k : cams) {
        const double d2 = (k.position.head<2>() - Eigen::Vector2d(x, y)).squaredNorm();
        const double wk = std::exp(-0.5 * d2 / (kLocalSigmaM * kLocalSigmaM)) + 1e-300;
        sum += wk * k.error, w += wk;
      }
      const Eigen::Vector3d e = w > 0 ? Eigen::Vector3d(sum / w) : Eigen::Vector3d::Zero();
      field.at<cv::Vec3d>(r, c) = {e.x(), e.y(), e.z()};
    }
  cv::Mat full;
  cv::resize(field, full, cv::Size(ccols * step, crows * step), 0, 0, cv::INTER_LINEAR);
  cv::Mat out(truth.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int r = 0; r < truth.rows; ++r)
    for (int c = 0; c < truth.cols; ++c) {
      const cv::Vec3d e = full.at<cv::Vec3d>(r, c);
      // Truth at (x − ex, y − ey), bilinear, then raised by ez.
      const double fc = c - e[0] / grid.cell, fr = r + e[1] / grid.cell;
      const int c0 = static_cast<int>(std::floor(fc)), r0 = static_cast<int>(std::floor(fr));
      if (c0 < 0 || r0 < 0 || c0 + 1 >= truth.cols || r0 + 1 >= truth.rows) continue;
      const double ac = fc - c0, ar = fr - r0;
      const double v = (1 - ar) * ((1 - ac) * truth.at<float>(r0, c0) + ac * truth.at<float>(r0, c0 + 1)) +
                       ar * ((1 - ac) * truth.at<float>(r0 + 1, c0) + ac * truth.at<float>(r0 + 1, c0 + 1));
      out.at<float>(r, c) = static_cast<float>(v + e[2]);
    }
  return out;
}

// The mesh's surface (offset added back), rasterised on the DSM's grid like the truth, against it:
// what a user of the mesh sees, decimation included.
HeightErrors CompareMesh(const fs::path& dir, const Raster& truth, const cv::Mat& road, int64_t* vertices) {
  const nlohmann::json j = ReadJsonFile(dir / "mesh.json");
  const Eigen::Vector3d off(j.at("offset")[0].get<double>(), j.at("offset")[1].get<double>(),
                            j.at("offset")[2].get<double>());
  TriangleMesh m = ReadPlyMesh(dir / "mesh.ply");
  *vertices = static_cast<int64_t>(m.vertices.size());
  for (Eigen::Vector3d& p : m.vertices) p += off;
  return Compare(RasterizeMesh(m.vertices, m.faces, truth, Eigen::Vector3d::Zero()), truth.z, road);
}

void WriteErrorImage(const fs::path& path, const cv::Mat& ours, const cv::Mat& truth) {
  constexpr double kRangeM = 0.02;
  cv::Mat diff = ours - truth, grey;
  diff.convertTo(grey, CV_8U, 127.5 / kRangeM, 127.5);
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar::all(0), FiniteMask(diff) == 0);
  std::vector<uchar> png;
  if (!cv::imencode(".png", colour, png)) throw WriteError(path, "PNG encoding failed");
  WriteFileChecked(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace

nlohmann::json HeightErrors::ToJson() const {
  return {{"cells", cells},         {"rmse_m", rmse_m},       {"mean_m", mean_m},        {"median_abs_m", median_abs_m},
          {"p95_abs_m", p95_abs_m}, {"max_abs_m", max_abs_m}, {"within_5mm", within_5mm}};
}

SurfaceEvaluation EvaluateSurface(const fs::path& survey_dir, const fs::path& output_dir, const fs::path& error_image) {
  const fs::path out = SurveyOutputDir(survey_dir, output_dir);
  const fs::path dir = out / "surface";
  if (!fs::exists(dir / "dsm.tif"))
    throw InputError(InputLocation::File((dir / "dsm.tif").string()),
                     fmt::format("no DSM: run `roadsurvey run {}` first", (survey_dir / "survey.json").string()));
  const GeoTiffRaster dsm = ReadGeoTiff(dir / "dsm.tif");
  Raster ours{dsm.image.clone(), dsm.georef.x_min, dsm.georef.y_max, dsm.georef.cell};
  ours.z.setTo(std::numeric_limits<float>::quiet_NaN(), ours.z == static_cast<float>(dsm.nodata));
  const GeoreferenceFile geo = ReadGeoreferenceFile(out / "georeference.json");
  const auto crs = geo.MakeCrs();
  const EnuOrigin o = ReadEnuOrigin(survey_dir / "truth/georeference.json");
  const GeographicLib::LocalCartesian truth_enu(o.lat_deg, o.lon_deg, o.h_ellipsoid_m);

  TriangleMesh truth = ReadPlyMesh(survey_dir / "truth/road_surface.ply");
  for (Eigen::Vector3d& p : truth.vertices) {
    Geodetic g;
    truth_enu.Reverse(p.x(), p.y(), p.z(), g.lat_deg, g.lon_deg, g.h_ellipsoid_m);
    p = crs->Forward(g);
  }
  SurfaceEvaluation e;
  e.cell_m = ours.cell;
  e.epsg = crs->epsg();
  const std::vector<CameraError> cams =
      CameraErrorsCrs(out / "cameras.csv", survey_dir / "truth/trajectory.tum", truth_enu, *crs);
  e.placement_cameras = static_cast<int>(cams.size());
  for (const CameraError& k : cams) e.placement_offset_m += k.error / static_cast<double>(cams.size());
  const cv::Mat truth_abs = RasterizeMesh(truth.vertices, truth.faces, ours, Eigen::Vector3d::Zero());
  Raster truth_rel = ours;
  truth_rel.z = TruthAsPlaced(truth_abs, ours, cams);
  const cv::Mat road = Carriageway(truth_abs);
  e.absolute = Compare(ours.z, truth_abs, road);
  e.relative = Compare(ours.z, truth_rel.z, road);
  e.all_cells = Compare(ours.z, truth_rel.z, cv::Mat());
  if (fs::exists(dir / "dsm_sigma.tif")) {
    const GeoTiffRaster sigma = ReadGeoTiff(dir / "dsm_sigma.tif");
    int64_t n = 0, within = 0;
    double sum = 0;
    for (int r = 0; r < ours.z.rows; ++r)
      for (int c = 0; c < ours.z.cols; ++c) {
        const float d = ours.z.at<float>(r, c) - truth_rel.z.at<float>(r, c), s = sigma.image.at<float>(r, c);
        if (!std::isfinite(d) || road.at<uint8_t>(r, c) == 0 || !(s > 0)) continue;
        ++n, sum += s, within += std::abs(d) <= 2 * s;
      }
    e.within_2_sigma = n ? double(within) / n : 0;
    e.mean_sigma_m = n ? sum / n : 0;
  }
  if (!error_image.empty()) WriteErrorImage(error_image, ours.z, truth_rel.z);
  // Searched about the cameras' mean horizontal placement error, which may be metres with a
  // standard GNSS: what is left is the surface's own offset.
  const Eigen::Vector3d placed_xy(e.placement_offset_m.x(), e.placement_offset_m.y(), 0);
  const Eigen::Vector2d own =
      PlanimetricOffset(ours.z, RasterizeMesh(truth.vertices, truth.faces, ours, placed_xy), ours.cell);
  e.planimetric_offset_m = e.placement_offset_m.head<2>() + own;
  e.planimetric_error_m = e.planimetric_offset_m.norm();
  e.planimetric_relative_m = own.norm();
  MeasureHoles(ours.z, road, ours.cell, {ours.x_min, ours.y_max}, &e);
  if (fs::exists(dir / "mesh.ply")) e.mesh = CompareMesh(dir, truth_rel, road, &e.mesh_vertices);
  return e;
}

std::string SurfaceEvaluation::Table() const {
  std::string s = fmt::format("surface vs truth/road_surface.ply ({}; cell {:.0f} mm)\n",
                              epsg.empty() ? "local ENU" : epsg, cell_m * 1000);
  const auto row = [](const char* name, const HeightErrors& h) {
    return fmt::format(
        "  {:<38} RMSE {:6.2f} mm  mean {:+6.2f}  median |e| {:5.2f}  p95 {:6.2f}  max {:6.1f} mm; {:5.1f} % within 5 "
        "mm "
        "({} cells)\n",
        name, h.rmse_m * 1000, h.mean_m * 1000, h.median_abs_m * 1000, h.p95_abs_m * 1000, h.max_abs_m * 1000,
        h.within_5mm * 100, h.cells);
  };
  s += "  carriageway (kerb faces and 2 cells beside them excluded):\n";
  s += row("DSM heights, absolute", absolute);
  s += row("DSM heights, cameras' local error removed", relative);
  if (mesh_vertices > 0) s += row("mesh surface, the same", mesh);
  s += row("every fused cell (verges, kerbs), the same", all_cells);
  s += fmt::format("  stated sigma: mean {:.2f} mm; {:.1f} % of the carriageway's cells within 2 sigma (relative)\n",
                   mean_sigma_m * 1000, within_2_sigma * 100);
  s += fmt::format("  cameras' placement error (ours - truth): E {:+.3f} N {:+.3f} U {:+.3f} m over {} cameras\n",
                   placement_offset_m.x(), placement_offset_m.y(), placement_offset_m.z(), placement_cameras);
  s += fmt::format("  DSM planimetric offset: E {:+.3f} N {:+.3f} m (|{:.3f}| m; {:.3f} m beyond the cameras')\n",
                   planimetric_offset_m.x(), planimetric_offset_m.y(), planimetric_error_m, planimetric_relative_m);
  s += fmt::format("  imaged carriageway: {} cells, {:.2f} % filled; largest hole {:.0f} mm, {} hole(s) over 50 mm\n",
                   road_cells, filled_fraction * 100, largest_hole_m * 1000, holes_over_5cm);
  return s;
}

nlohmann::json SurfaceEvaluation::ToJson() const {
  return {{"cell_m", cell_m},
          {"epsg", epsg},
          {"absolute", absolute.ToJson()},
          {"relative", relative.ToJson()},
          {"all_cells", all_cells.ToJson()},
          {"mean_sigma_m", mean_sigma_m},
          {"within_2_sigma", within_2_sigma},
          {"placement_offset_m", {placement_offset_m.x(), placement_offset_m.y(), placement_offset_m.z()}},
          {"placement_cameras", placement_cameras},
          {"planimetric_offset_m", {planimetric_offset_m.x(), planimetric_offset_m.y()}},
          {"planimetric_error_m", planimetric_error_m},
          {"planimetric_relative_m", planimetric_relative_m},
          {"road_cells", road_cells},
          {"filled_fraction", filled_fraction},
          {"largest_hole_m", largest_hole_m},
          {"holes_over_5cm", holes_over_5cm},
          {"holes",
           [&] {
             nlohmann::json h = nlohmann::json::array();
             for (const Eigen::Vector3d& x : holes) h.push_back({{"x", x.x()}, {"y", x.y()}, {"width_m", x.z()}});
             return h;
           }()},
          {"mesh", mesh.ToJson()},
          {"mesh_vertices", mesh_vertices}};
}

}  // namespace rs
