#include "stages/surface/surface_frames.h"

#include <GeographicLib/LocalCartesian.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "formats/disparity/disparity_io.h"
#include "formats/input_error.h"
#include "formats/stereo/image_io.h"

namespace rs {
namespace fs = std::filesystem;

Eigen::Matrix<double, 3, 4> CrsFromCamera(const Eigen::Isometry3d& T_world_camera, const GeoreferenceFile& geo,
                                          const OutputCrs& crs) {
  const GeographicLib::LocalCartesian enu(geo.origin.lat_deg, geo.origin.lon_deg, geo.origin.h_ellipsoid_m);
  const auto to_crs = [&](const Eigen::Vector3d& p) {
    Geodetic g;
    enu.Reverse(p.x(), p.y(), p.z(), g.lat_deg, g.lon_deg, g.h_ellipsoid_m);
    return crs.Forward(g);
  };
  const Eigen::Vector3d p0 = geo.ToEnu(T_world_camera.translation());
  constexpr double kStep = 5.0;  // m: central differences, second-order error ~ step² · curvature
  Eigen::Matrix3d J;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(k) * kStep;
    J.col(k) = (to_crs(p0 + e) - to_crs(p0 - e)) / (2 * kStep);
  }
  const Eigen::Vector3d c0 = to_crs(p0);
  // camera -> SLAM world -> ENU (similarity) -> CRS (affine about p0)
  const Eigen::Matrix3d enu_lin = geo.scale * geo.R * T_world_camera.linear();
  const Eigen::Vector3d enu_off = geo.ToEnu(T_world_camera.translation());
  Eigen::Matrix<double, 3, 4> M;
  M.leftCols<3>() = J * enu_lin;
  M.col(3) = c0 + J * (enu_off - p0);
  return M;
}

namespace {

// The road fit's residual disparity RMS (px) of a frame, 0 when not stated.
double RoadResidualPx(const fs::path& road_model) {
  if (road_model.empty() || !fs::exists(road_model)) return 0;
  std::ifstream in(road_model);
  const auto j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("residual_rms_px") || !j["residual_rms_px"].is_number())
    throw InputError(InputLocation::File(road_model.string()), "not a road model (no residual_rms_px)");
  return j["residual_rms_px"].get<double>();
}

}  // namespace

FrameView LoadFrameView(const SurfaceFrame& f, const RectifiedStereo& camera, const FrameLoadOptions& o) {
  FrameView v;
  v.camera = camera;
  v.crs_from_camera = f.crs_from_camera;
  v.max_range_m = o.max_range_m;
  v.disparity_px = ReadKittiDisparityPng(f.disparity);
  if (!f.disparity_sharp.empty() && fs::exists(f.damage_labels)) {
    const cv::Mat labels = cv::imread(f.damage_labels.string(), cv::IMREAD_UNCHANGED);
    if (labels.size() != v.disparity_px.size() || labels.channels() != 1)
      throw InputError(InputLocation::File(f.damage_labels.string()), "not a label image of the disparity's size");
    cv::Mat near_damage = labels != 0;
    if (cv::countNonZero(near_damage) > 0) {
      const int k = 2 * o.damage_margin_px + 1;
      cv::dilate(near_damage, near_damage, cv::getStructuringElement(cv::MORPH_ELLIPSE, {k, k}));
      ReadKittiDisparityPng(f.disparity_sharp).copyTo(v.disparity_px, near_damage);
    }
  }
  const double sigma = o.disparity_sigma_px > 0 ? o.disparity_sigma_px : RoadResidualPx(f.road_model);
  v.sigma_disparity_px = std::max(sigma, o.min_disparity_sigma_px);
  v.use = cv::imread(f.road_mask.string(), cv::IMREAD_UNCHANGED);
  if (v.use.type() != CV_8UC1 || v.use.size() != v.disparity_px.size())
    throw InputError(InputLocation::File(f.road_mask.string()), "not an 8-bit road mask of the disparity's size");
  if (o.colour) {
    v.colour = LoadColor8(f.left);
    if (v.colour.size() != v.disparity_px.size())
      throw InputError(InputLocation::File(f.left.string()), "image size differs from the frame's disparity");
  }
  return v;
}

}  // namespace rs
