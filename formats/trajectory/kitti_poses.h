#pragma once
// KITTI odometry poses: one pose per line, the 3x4 matrix [R | t] row-major (12 numbers separated by
// blanks), the left camera's pose in the first camera frame. No times in the file: they come from the
// sequence's times.txt (one decimal seconds value per line) or the pose index stands in for them.

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "formats/trajectory/trajectory.h"

namespace rs {

/// Poses in file order. Throws InputError (path:line:column) on a wrong field count, a non-number, a
/// non-finite value, or a matrix that is not a rotation up to print rounding (||R^T R - I||_F <= 1e-3,
/// det > 0; re-orthonormalised). Blank lines are an error (they would shift every later index).
std::vector<Eigen::Isometry3d> ReadKittiPoses(std::istream& in, const std::string& path_for_errors);

/// times.txt: one time in seconds per line (exact decimal parse), never decreasing.
std::vector<int64_t> ReadKittiTimes(std::istream& in, const std::string& path_for_errors);

/// Joins poses with times. Without times, t_ns is the pose index and has_times is false.
/// Throws InputError on the times file when the counts differ.
Trajectory MakeKittiTrajectory(const std::vector<Eigen::Isometry3d>& poses, const std::string& poses_path,
                               const std::optional<std::vector<int64_t>>& times_ns, const std::string& times_path);

/// Path wrapper: poses file plus optional times.txt.
Trajectory ReadKittiTrajectory(const std::filesystem::path& poses_path,
                               const std::optional<std::filesystem::path>& times_path);

/// Writes the 3x4 rows with 17 significant digits (lossless); times are not written.
void WriteKittiPoses(std::ostream& out, const Trajectory& trajectory);
void WriteKittiPoses(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace rs
