#include "formats/trajectory/euroc_trajectory.h"

#include <fstream>

#include <fmt/format.h>

#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "formats/trajectory/trajectory_text.h"

namespace rs {

using namespace trajectory_text;

Trajectory ReadEurocTrajectory(std::istream& in, const std::string& path) {
  Trajectory trajectory;
  trajectory.source = path;
  LineReader reader(in, path);
  std::string line;
  while (reader.Next(&line)) {
    if (IsBlankOrComment(line)) continue;
    const int64_t n = reader.line_number();
    const std::vector<Field> f = SplitCsv(line);
    if (f.size() < 8) {
      throw InputError(InputLocation::Line(path, n), fmt::format("expected at least 8 comma-separated fields "
                                                                 "(t[ns], px, py, pz, qw, qx, qy, qz), got {}",
                                                                 f.size()));
    }
    StampedPose pose;
    pose.t_ns = ParseNsField(f[0], path, n);
    CheckNotDecreasing(trajectory.poses.empty() ? 0 : trajectory.poses.back().t_ns, pose.t_ns,
                       !trajectory.poses.empty(), path, n, f[0].column);
    double v[7];
    static const char* kNames[7] = {"p_x", "p_y", "p_z", "q_w", "q_x", "q_y", "q_z"};
    for (int k = 0; k < 7; ++k) v[k] = ParseFinite(f[k + 1], path, n, kNames[k]);
    pose.T_world_frame.linear() = CheckedQuaternion(v[3], v[4], v[5], v[6], path, n, f[4].column).toRotationMatrix();
    pose.T_world_frame.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

Trajectory ReadEurocTrajectory(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open trajectory file");
  return ReadEurocTrajectory(in, path.string());
}

void WriteEurocTrajectory(std::ostream& out, const Trajectory& trajectory) {
  out << "#timestamp [ns], p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n";
  for (const StampedPose& p : trajectory.poses) {
    const Eigen::Vector3d t = p.T_world_frame.translation();
    const Eigen::Quaterniond q(p.T_world_frame.linear());
    out << fmt::format("{},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", p.t_ns, t.x(), t.y(), t.z(),
                       q.w(), q.x(), q.y(), q.z());
  }
}

void WriteEurocTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  WriteStreamChecked(path, [&](std::ostream& out) { WriteEurocTrajectory(out, trajectory); });
}

}  // namespace rs
