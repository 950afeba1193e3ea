#pragma once
// COLMAP's model_aligner as a reference: a minimal COLMAP text model of a trajectory (one
// pinhole camera, one image per pose, no points) aligned to reference positions by
// `colmap model_aligner` (robust, scale estimated, its defaults otherwise), read back.

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace rs {

/// Aligned left camera-to-reference poses by t_ns, or nullopt with `why` set when colmap is
/// missing or fails. `refs` are reference positions (same frame as the result) by t_ns.
std::optional<std::map<int64_t, Eigen::Isometry3d>> AlignWithColmap(
    const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& T_world_cam, const std::map<int64_t, Eigen::Vector3d>& refs,
    double max_error_m, const std::filesystem::path& work_dir, std::string* why);

}  // namespace rs
