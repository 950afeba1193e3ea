#pragma once
// Reading a trajectory file of any supported format, named or detected from its first data line.

#include <filesystem>
#include <optional>
#include <string_view>

#include "formats/trajectory/trajectory.h"

namespace rs {

/// Trajectory text formats read and written by rs_trajectory_io.
enum class TrajectoryFormat { kTum, kKitti, kEuroc };

/// "tum", "kitti", "euroc" (also "asl"); nullopt otherwise.
std::optional<TrajectoryFormat> ParseTrajectoryFormat(std::string_view name);
const char* TrajectoryFormatName(TrajectoryFormat format);

/// From the first non-comment line: comma-separated with an integer first field -> EuRoC,
/// 12 numbers -> KITTI, 8 numbers -> TUM. Throws InputError when it is none of these or the file is empty.
TrajectoryFormat DetectTrajectoryFormat(const std::filesystem::path& path);

/// Reads `path` in `format` (detected when nullopt). `kitti_times` is used only for KITTI.
Trajectory ReadTrajectory(const std::filesystem::path& path, std::optional<TrajectoryFormat> format,
                          const std::optional<std::filesystem::path>& kitti_times = std::nullopt);

}  // namespace rs
