#include "formats/trajectory/tum_trajectory.h"

#include <fstream>

#include <fmt/format.h>

#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "formats/trajectory/timestamp_text.h"
#include "formats/trajectory/trajectory_text.h"

namespace rs {

using namespace trajectory_text;

Trajectory ReadTumTrajectory(std::istream& in, const std::string& path) {
  Trajectory trajectory;
  trajectory.source = path;
  LineReader reader(in, path);
  std::string line;
  while (reader.Next(&line)) {
    if (IsBlankOrComment(line)) continue;
    const int64_t n = reader.line_number();
    const std::vector<Field> f = SplitFields(line, " \t,");
    if (f.size() != 8) {
      throw InputError(InputLocation::Line(path, n, f.size() > 8 ? f[8].column : -1),
                       fmt::format("expected 8 fields (t tx ty tz qx qy qz qw), got {}", f.size()));
    }
    StampedPose pose;
    pose.t_ns = ParseSecondsField(f[0], path, n);
    CheckNotDecreasing(trajectory.poses.empty() ? 0 : trajectory.poses.back().t_ns, pose.t_ns,
                       !trajectory.poses.empty(), path, n, f[0].column);
    double v[7];
    static const char* kNames[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    for (int k = 0; k < 7; ++k) v[k] = ParseFinite(f[k + 1], path, n, kNames[k]);
    pose.T_world_frame.linear() = CheckedQuaternion(v[6], v[3], v[4], v[5], path, n, f[4].column).toRotationMatrix();
    pose.T_world_frame.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

Trajectory ReadTumTrajectory(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open trajectory file");
  return ReadTumTrajectory(in, path.string());
}

void WriteTumTrajectory(std::ostream& out, const Trajectory& trajectory) {
  out << "# timestamp[s] tx ty tz qx qy qz qw\n";
  for (const StampedPose& p : trajectory.poses) {
    const Eigen::Vector3d t = p.T_world_frame.translation();
    const Eigen::Quaterniond q(p.T_world_frame.linear());
    out << fmt::format("{} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}\n", FormatNsAsSeconds(p.t_ns), t.x(),
                       t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  }
}

void WriteTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  WriteStreamChecked(path, [&](std::ostream& out) { WriteTumTrajectory(out, trajectory); });
}

}  // namespace rs
