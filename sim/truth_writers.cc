#include "sim/truth_writers.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "formats/geojson/geojson.h"

namespace rs::sim {
namespace {

std::ofstream OpenOut(const std::filesystem::path& path) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot write " + path.string());
  return f;
}

void CloseChecked(std::ofstream& f, const std::filesystem::path& path) {
  f.close();
  if (!f) throw std::runtime_error("error writing " + path.string());
}

geojson::Position ToLonLat(const RoadScene& scene, const GeographicLib::LocalCartesian& enu,
                           const Eigen::Vector2d& sl) {
  const Eigen::Vector2d xy = scene.road().ToWorld(sl.x(), sl.y());
  const double z = scene.road().IntactZ(sl.x(), sl.y());
  double lat, lon, h;
  enu.Reverse(xy.x(), xy.y(), z, lat, lon, h);
  return {lon, lat, std::nullopt};
}

}  // namespace

void WriteTum(const std::filesystem::path& path, const std::vector<int64_t>& t_ns,
              const std::vector<Eigen::Isometry3d>& T_world_cam) {
  std::ofstream f = OpenOut(path);
  f << "# t_s tx ty tz qx qy qz qw  (camera-to-world; world = local ENU at the origin in georeference.json;"
       " t_s = camera clock, UTC seconds)\n";
  for (size_t k = 0; k < t_ns.size(); ++k) {
    const Eigen::Quaterniond q(T_world_cam[k].linear());
    const Eigen::Vector3d& t = T_world_cam[k].translation();
    f << fmt::format("{}.{:09d} {:.6f} {:.6f} {:.6f} {:.9f} {:.9f} {:.9f} {:.9f}\n", t_ns[k] / 1'000'000'000,
                     t_ns[k] % 1'000'000'000, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  }
  CloseChecked(f, path);
}

void WriteReferenceTrajectory(const std::filesystem::path& path, const std::vector<int64_t>& t_ns,
                              const std::vector<Eigen::Isometry3d>& T_world_cam,
                              const GeographicLib::LocalCartesian& enu) {
  std::ofstream f = OpenOut(path);
  f << "t_ns,lat_deg,lon_deg,h_ellipsoid_m\n";
  for (size_t k = 0; k < t_ns.size(); ++k) {
    const Eigen::Vector3d& p = T_world_cam[k].translation();
    double lat = 0, lon = 0, h = 0;
    enu.Reverse(p.x(), p.y(), p.z(), lat, lon, h);
    f << fmt::format("{},{:.10f},{:.10f},{:.4f}\n", t_ns[k], lat, lon, h);
  }
  CloseChecked(f, path);
}

cv::Mat DisparityFromDepth(const cv::Mat& depth_m, double fb) {
  cv::Mat out(depth_m.size(), CV_16UC1);
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* z = depth_m.ptr<float>(v);
    uint16_t* d = out.ptr<uint16_t>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      const double q = z[u] > 0 ? fb / z[u] * 256.0 : 0.0;
      // Rounded like lround (q >= 0) without a libm call per pixel; 0 outside 1..65535.
      d[u] = (q >= 0.5 && q < 65535.5) ? static_cast<uint16_t>(q + 0.5) : 0;
    }
  }
  return out;
}

void WriteDamagesGeoJson(const std::filesystem::path& path, const RoadScene& scene,
                         const GeographicLib::LocalCartesian& enu) {
  geojson::FeatureCollection fc;
  for (const Damage& d : scene.damages()) {
    geojson::Feature f;
    std::vector<geojson::Position> pts;
    for (const auto& p : d.outline_sl) pts.push_back(ToLonLat(scene, enu, p));
    const bool crack = d.type == DamageType::kCrackLongitudinal || d.type == DamageType::kCrackTransverse;
    if (crack) {
      f.geometry = geojson::LineString{pts};
    } else {
      f.geometry = geojson::Polygon{{pts}};
    }
    nlohmann::json p = {{"id", d.id},
                        {"type", ToString(d.type)},
                        {"area_m2", d.area_m2},
                        {"max_depth_m", d.max_depth_m},
                        {"mean_depth_m", d.mean_depth_m},
                        {"volume_m3", d.volume_m3},
                        {"severity", d.severity},
                        {"severity_standard", d.severity_standard}};
    if (d.type == DamageType::kPothole) {
      p["mean_diameter_m"] = d.mean_diameter_m;
      if (d.mean_diameter_m > 0.75) p["equivalent_potholes"] = d.area_m2 / 0.5;
    }
    if (crack || d.type == DamageType::kAlligator) p["width_m"] = d.width_m;
    if (crack) p["length_m"] = d.length_m;
    f.properties = std::move(p);
    f.id = std::to_string(d.id);
    fc.features.push_back(std::move(f));
  }
  geojson::WriteFeatureCollection(path, fc);
}

void WriteRoadPly(const std::filesystem::path& path, const RoadScene& scene, double s0, double s1, double half_w,
                  double res) {
  const int ns = std::max(2, static_cast<int>(std::ceil((s1 - s0) / res)) + 1);
  const int nl = std::max(2, static_cast<int>(std::ceil(2 * half_w / res)) + 1);
  std::ofstream f = OpenOut(path);
  f << "ply\nformat binary_little_endian 1.0\n"
    << "comment roadsurvey simulate: true road surface, local ENU metres (see georeference.json)\n"
    << "element vertex " << static_cast<int64_t>(ns) * nl << "\nproperty float x\nproperty float y\nproperty float z\n"
    << "element face " << 2 * static_cast<int64_t>(ns - 1) * (nl - 1) << "\nproperty list uchar int vertex_indices\n"
    << "end_header\n";
  std::vector<char> buf;
  buf.reserve(static_cast<size_t>(nl) * 12);
  for (int i = 0; i < ns; ++i) {
    const double s = std::min(s1, s0 + i * res);
    buf.clear();
    for (int j = 0; j < nl; ++j) {
      const double l = std::min(half_w, -half_w + j * res);
      const Eigen::Vector2d xy = scene.road().ToWorld(s, l);
      const float v[3] = {static_cast<float>(xy.x()), static_cast<float>(xy.y()),
                          static_cast<float>(scene.HeightAt(xy.x(), xy.y()))};
      const char* b = reinterpret_cast<const char*>(v);
      buf.insert(buf.end(), b, b + sizeof(v));
    }
    f.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  }
  for (int i = 0; i + 1 < ns; ++i) {
    buf.clear();
    for (int j = 0; j + 1 < nl; ++j) {
      const int a = i * nl + j, b = (i + 1) * nl + j, c = (i + 1) * nl + j + 1, d = i * nl + j + 1;
      // Counter-clockwise seen from above (+z): s runs along the road, l to its left.
      const int tris[2][3] = {{a, b, c}, {a, c, d}};
      for (const auto& tri : tris) {
        char rec[13];
        rec[0] = 3;
        std::memcpy(rec + 1, tri, 12);
        buf.insert(buf.end(), rec, rec + 13);
      }
    }
    f.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  }
  CloseChecked(f, path);
}

void WriteGeoreference(const std::filesystem::path& path, const SimulationOptions& o) {
  const nlohmann::json j = {
      {"format", "roadsurvey-georeference-v1"},
      {"frame", "local ENU (x east, y north, z up), metres, tangent at the origin"},
      {"ellipsoid", "WGS84"},
      {"origin", {{"lat_deg", o.origin_lat_deg}, {"lon_deg", o.origin_lon_deg}, {"h_ellipsoid_m", o.origin_h_m}}},
      {"conversion", "GeographicLib::LocalCartesian(lat_deg, lon_deg, h_ellipsoid_m)"},
      {"applies_to", {"truth/trajectory.tum", "truth/road_surface.ply"}}};
  std::ofstream f = OpenOut(path);
  f << j.dump(2) << "\n";
  CloseChecked(f, path);
}

}  // namespace rs::sim
