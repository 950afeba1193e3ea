#pragma once
// Map point positions from a SLAM map folder (map/points.txt: one point a line, `id x y z`
// followed by its observations). Only the positions are needed to find the road plane.

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rs {

/// Throws InputError (path:line) on a line whose first four fields are not an id and 3 finite numbers.
std::vector<Eigen::Vector3d> ReadMapPointPositions(std::istream& in, const std::string& path_for_errors);
/// Reads `map_dir`/points.txt; throws InputError when it is missing.
std::vector<Eigen::Vector3d> ReadMapPointPositions(const std::filesystem::path& map_dir);

}  // namespace rs
