#pragma once
// TUM RGB-D benchmark trajectory text: one pose per line, `t tx ty tz qx qy qz qw`,
// t in seconds (decimal, parsed exactly into ns), translation in metres, Hamilton quaternion
// with w last. '#' lines and blank lines are skipped. Fields are separated by spaces, tabs or commas.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/trajectory/trajectory.h"

namespace rs {

/// Throws InputError (path:line:column) on a wrong field count, a non-number, a non-finite value,
/// a non-unit quaternion (normalised if ||q| - 1| <= 1e-3) or a timestamp before the previous one.
Trajectory ReadTumTrajectory(std::istream& in, const std::string& path_for_errors);
Trajectory ReadTumTrajectory(const std::filesystem::path& path);

/// Writes t with nine decimals (exact ns) and the pose with 17 significant digits (lossless).
void WriteTumTrajectory(std::ostream& out, const Trajectory& trajectory);
void WriteTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace rs
