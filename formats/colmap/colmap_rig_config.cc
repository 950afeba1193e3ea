// The rig configuration of `colmap rig_bundle_adjuster` (COLMAP 3.8, src/exe/sfm.cc, ReadCameraRigConfig).
#include <istream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "formats/colmap/colmap_io.h"
#include "formats/input_error.h"

namespace rs {

std::string ColmapRigConfigJson(const std::vector<ColmapRig>& rigs) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& rig : rigs) {
    nlohmann::json cams = nlohmann::json::array();
    for (const auto& c : rig.cameras) {
      Eigen::Quaterniond q(c.T_cam_rig.linear());
      q.normalize();
      const Eigen::Vector3d t = c.T_cam_rig.translation();
      cams.push_back({{"camera_id", c.camera_id},
                      {"image_prefix", c.image_prefix},
                      {"rel_tvec", {t.x(), t.y(), t.z()}},
                      {"rel_qvec", {q.w(), q.x(), q.y(), q.z()}}});
    }
    out.push_back({{"ref_camera_id", rig.ref_camera_id}, {"cameras", cams}});
  }
  return out.dump(2) + "\n";
}

std::vector<ColmapRig> ReadColmapRigConfig(std::istream& in, const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(InputLocation::Byte(path, static_cast<int64_t>(e.byte) - 1), "not JSON");
  }
  const auto fail = [&](const std::string& message) -> void { throw InputError(InputLocation::File(path), message); };
  if (!j.is_array()) fail("expected a list of rigs");
  std::vector<ColmapRig> rigs;
  for (size_t i = 0; i < j.size(); ++i) {
    const auto& r = j[i];
    if (!r.is_object() || !r.contains("ref_camera_id") || !r["ref_camera_id"].is_number_unsigned() ||
        !r.contains("cameras") || !r["cameras"].is_array())
      fail(fmt::format("rig {}: expected ref_camera_id (unsigned) and cameras (list)", i));
    ColmapRig rig;
    rig.ref_camera_id = r["ref_camera_id"].get<uint32_t>();
    for (const auto& c : r["cameras"]) {
      if (!c.is_object() || !c.contains("camera_id") || !c["camera_id"].is_number_unsigned() ||
          !c.contains("image_prefix") || !c["image_prefix"].is_string())
        fail(fmt::format("rig {}: each camera needs camera_id (unsigned) and image_prefix (string)", i));
      ColmapRigCamera cam;
      cam.camera_id = c["camera_id"].get<uint32_t>();
      cam.image_prefix = c["image_prefix"].get<std::string>();
      if (c.contains("rel_tvec") || c.contains("rel_qvec")) {
        const auto& t = c.value("rel_tvec", nlohmann::json());
        const auto& q = c.value("rel_qvec", nlohmann::json());
        const auto numbers = [](const nlohmann::json& a, size_t n) {
          if (!a.is_array() || a.size() != n) return false;
          for (const auto& v : a)
            if (!v.is_number()) return false;
          return true;
        };
        if (!numbers(t, 3) || !numbers(q, 4)) fail(fmt::format("rig {} camera {}: rel_tvec needs 3 numbers and rel_qvec 4", i, cam.camera_id));
        const Eigen::Quaterniond quat(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>());
        if (std::abs(quat.norm() - 1) > 1e-3) fail(fmt::format("rig {} camera {}: rel_qvec is not a unit quaternion", i, cam.camera_id));
        cam.T_cam_rig.linear() = quat.normalized().toRotationMatrix();
        cam.T_cam_rig.translation() = Eigen::Vector3d(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
      }
      rig.cameras.push_back(cam);
    }
    rigs.push_back(std::move(rig));
  }
  return rigs;
}

}  // namespace rs
