#include "stages/georeference/georeference_outputs.h"

#include <fmt/format.h>

#include <cmath>
#include <sstream>

#include "formats/checked_file.h"
#include "formats/geojson/geojson.h"

namespace rs {
namespace {

Geodetic ToGeodetic(const GeoFrames& g, const Eigen::Vector3d& p_enu) {
  Geodetic out;
  g.enu.Reverse(p_enu.x(), p_enu.y(), p_enu.z(), out.lat_deg, out.lon_deg, out.h_ellipsoid_m);
  return out;
}

nlohmann::json AxisStats(const std::vector<GnssResidual>& res, bool inliers_only) {
  Eigen::Vector3d ss = Eigen::Vector3d::Zero(), mx = Eigen::Vector3d::Zero(), sum = Eigen::Vector3d::Zero();
  double hh = 0, hmax = 0;
  int n = 0;
  for (const auto& r : res) {
    if (inliers_only && !r.inlier) continue;
    ss += r.r_enu.cwiseAbs2();
    sum += r.r_enu;
    mx = mx.cwiseMax(r.r_enu.cwiseAbs());
    hh += r.r_enu.head<2>().squaredNorm();
    hmax = std::max(hmax, r.r_enu.head<2>().norm());
    ++n;
  }
  if (n == 0) return {{"frames", 0}};
  const Eigen::Vector3d rmse = (ss / n).cwiseSqrt(), mean = sum / n;
  return {{"frames", n},
          {"rmse_m", {{"east", rmse.x()}, {"north", rmse.y()}, {"up", rmse.z()}, {"horizontal", std::sqrt(hh / n)}}},
          {"max_abs_m", {{"east", mx.x()}, {"north", mx.y()}, {"up", mx.z()}, {"horizontal", hmax}}},
          {"mean_m", {{"east", mean.x()}, {"north", mean.y()}, {"up", mean.z()}}}};
}

std::vector<double> RowMajor(const Eigen::Matrix3d& R) {
  return {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)};
}

}  // namespace

void WriteCamerasCsv(const std::filesystem::path& path, const GeoreferenceResult& result, const GeoFrames& g) {
  std::ostringstream out;
  out << "frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,yaw_deg,status\n";
  for (const auto& c : result.cameras) {
    out << c.frame << ',' << c.t_ns << ',';
    if (c.status == CameraStatus::kSkipped) {
      out << ",,,,,,,,," << ToString(c.status) << '\n';
      continue;
    }
    const Geodetic geo = ToGeodetic(g, c.p_enu);
    const Eigen::Vector3d x = g.crs->Forward(geo);
    out << fmt::format("{:.4f},{:.4f},{:.4f},{:.10f},{:.10f},{:.4f},", x.x(), x.y(), x.z(), geo.lat_deg, geo.lon_deg,
                       geo.h_ellipsoid_m);
    if (c.R_ned_body) {
      const Eigen::Vector3d ypr = YawPitchRollDeg(*c.R_ned_body);
      out << fmt::format("{:.4f},{:.4f},{:.4f},", ypr.z(), ypr.y(), ypr.x());
    } else {
      out << ",,,";
    }
    out << ToString(c.status) << '\n';
  }
  WriteFileChecked(path, out.view());
}

void WriteTrajectoryGeoJson(const std::filesystem::path& path, const GeoreferenceResult& result, const GeoFrames& g) {
  geojson::LineString line;
  int visual = 0, gnss_only = 0;
  for (const auto& c : result.cameras) {
    if (c.status == CameraStatus::kSkipped) continue;
    (c.status == CameraStatus::kVisual ? visual : gnss_only)++;
    const Geodetic geo = ToGeodetic(g, c.p_enu);
    line.positions.push_back({geo.lon_deg, geo.lat_deg, geo.h_ellipsoid_m});
  }
  geojson::FeatureCollection fc;
  if (line.positions.size() >= 2) {
    geojson::Feature f{line};
    f.properties = {{"name", "left camera centres in time order"},
                    {"frames_visual", visual},
                    {"frames_gnss_only", gnss_only},
                    {"height", "WGS84 ellipsoidal height, m"}};
    fc.features.push_back(f);
  }
  std::ostringstream out;
  geojson::WriteFeatureCollection(out, fc);
  WriteFileChecked(path, out.view());
}

nlohmann::json GeoreferenceReport(const GeoreferenceResult& r, const GeoFrames& g, bool estimate_scale) {
  const auto& S = r.fit.transform;
  const Eigen::Vector3d origin_crs = g.crs->Forward(g.origin);
  nlohmann::json outliers = nlohmann::json::array();
  for (const auto& res : r.residuals)
    if (!res.inlier)
      outliers.push_back({{"frame", res.frame}, {"t_ns", res.t_ns}, {"residual_enu_m", {res.r_enu.x(), res.r_enu.y(), res.r_enu.z()}}});
  const double positions_sigma_deg =
      r.fit.roll_information > 0 ? 180.0 / M_PI / std::sqrt(r.fit.roll_information) : -1.0;
  nlohmann::json roll = {{"method", ToString(r.roll_method)},
                         {"observations", r.roll.observations},
                         {"angle_deg", r.roll.angle_rad * 180 / M_PI},
                         {"sigma_deg", r.roll.sigma_rad * 180 / M_PI},
                         {"positions_sigma_deg", positions_sigma_deg},
                         {"weight", r.roll.weight},
                         {"applied_deg", r.roll.applied_rad * 180 / M_PI}};
  if (r.roll_method == RollSource::kRoadPlane) roll["road_planes"] = r.road_planes;
  const Eigen::Vector3d axis_enu = S.R * r.fit.axis_slam;
  return {
      {"format", "roadsurvey-georeference-v1"},
      {"frame", "local ENU (x east, y north, z up), metres, tangent at the origin"},
      {"ellipsoid", "WGS84"},
      {"origin", {{"lat_deg", g.origin.lat_deg}, {"lon_deg", g.origin.lon_deg}, {"h_ellipsoid_m", g.origin.h_ellipsoid_m}}},
      {"conversion", "GeographicLib::LocalCartesian(lat_deg, lon_deg, h_ellipsoid_m)"},
      {"transform",
       {{"maps", "SLAM world (input trajectory and map) -> local ENU at the origin: p_enu = scale * R * p + t"},
        {"model", estimate_scale ? "Sim3" : "SE3"},
        {"scale", S.scale},
        {"scale_sigma", r.fit.scale_sigma},
        {"R_row_major", RowMajor(S.R)},
        {"t_m", {S.t.x(), S.t.y(), S.t.z()}},
        {"track_axis_enu", {axis_enu.x(), axis_enu.y(), axis_enu.z()}}}},
      {"crs",
       {{"spec", g.crs->spec()},
        {"epsg", g.crs->epsg()},
        {"wkt", g.crs->wkt()},
        {"heights", ToString(g.crs->heights())},
        {"origin_in_crs", {origin_crs.x(), origin_crs.y(), origin_crs.z()}}}},
      {"roll", roll},
      {"residuals",
       {{"definition", "GNSS fix minus fitted antenna position, local ENU, m"},
        {"robust_sigma_m", {{"east", r.fit.sigma_axis_m.x()}, {"north", r.fit.sigma_axis_m.y()}, {"up", r.fit.sigma_axis_m.z()}}},
        {"ransac_inliers", r.fit.ransac_inliers},
        {"inliers", AxisStats(r.residuals, true)},
        {"all", AxisStats(r.residuals, false)},
        {"outliers", outliers}}},
      {"angles", "cameras.csv roll/pitch/yaw: body FRD -> NED at the origin, aerospace ZYX, degrees (yaw from true north)"}};
}

void WriteGnssResidualCsv(const std::filesystem::path& path, const std::vector<GnssResidual>& residuals) {
  std::string csv = "frame,t_ns,east_m,north_m,up_m,inlier\n";
  for (const GnssResidual& r : residuals)
    csv += fmt::format("{},{},{:.4f},{:.4f},{:.4f},{}\n", r.frame, r.t_ns, r.r_enu.x(), r.r_enu.y(), r.r_enu.z(),
                       r.inlier ? 1 : 0);
  WriteFileChecked(path, csv);
}

}  // namespace rs
