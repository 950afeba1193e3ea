#pragma once
// EuRoC / ASL ground-truth CSV (state_groundtruth_estimate0/data.csv):
//   #timestamp [ns], p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], ...
// t in integer nanoseconds, the pose of the IMU body frame S in the reference frame R with the
// quaternion w first. Columns after the quaternion (velocity, biases) are ignored; at least 8 are required.
// '#' lines (the header) and blank lines are skipped.

#include <filesystem>
#include <iosfwd>
#include <string>

#include "formats/trajectory/trajectory.h"

namespace rs {

/// Throws InputError (path:line:column) on a wrong field count, a non-integer timestamp, a non-number,
/// a non-finite value, a non-unit quaternion (normalised if ||q| - 1| <= 1e-3) or decreasing times.
Trajectory ReadEurocTrajectory(std::istream& in, const std::string& path_for_errors);
Trajectory ReadEurocTrajectory(const std::filesystem::path& path);

/// Writes the 8 pose columns with the ASL header; positions and quaternions with 17 significant digits.
void WriteEurocTrajectory(std::ostream& out, const Trajectory& trajectory);
void WriteEurocTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace rs
