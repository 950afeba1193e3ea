#include "stages/georeference/map_points.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "formats/input_error.h"

namespace rs {

std::vector<Eigen::Vector3d> ReadMapPointPositions(std::istream& in, const std::string& path) {
  std::vector<Eigen::Vector3d> points;
  std::string line;
  int64_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    long long id;
    Eigen::Vector3d p;
    if (!(fields >> id >> p.x() >> p.y() >> p.z()) || !p.allFinite())
      throw InputError(InputLocation::Line(path, line_no), "expected a point id and x y z (finite numbers)");
    points.push_back(p);
  }
  return points;
}

std::vector<Eigen::Vector3d> ReadMapPointPositions(const std::filesystem::path& map_dir) {
  const auto path = map_dir / "points.txt";
  std::ifstream in(path);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open the SLAM map's points");
  return ReadMapPointPositions(in, path.string());
}

}  // namespace rs
