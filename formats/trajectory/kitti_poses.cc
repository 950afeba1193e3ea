#include "formats/trajectory/kitti_poses.h"

#include <fstream>

#include <fmt/format.h>

#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "formats/trajectory/trajectory_text.h"

namespace rs {

using namespace trajectory_text;

std::vector<Eigen::Isometry3d> ReadKittiPoses(std::istream& in, const std::string& path) {
  std::vector<Eigen::Isometry3d> poses;
  LineReader reader(in, path);
  std::string line;
  int64_t blank_line = -1;  // a blank line is fine only at the very end
  while (reader.Next(&line)) {
    const int64_t n = reader.line_number();
    const std::vector<Field> f = SplitFields(line, " \t");
    if (f.empty()) {
      if (blank_line < 0) blank_line = n;
      continue;
    }
    if (blank_line >= 0) {
      throw InputError(InputLocation::Line(path, blank_line), "blank line inside KITTI poses (would shift indices)");
    }
    if (f.size() != 12) {
      throw InputError(InputLocation::Line(path, n, f.size() > 12 ? f[12].column : -1),
                       fmt::format("expected 12 numbers (3x4 row-major [R|t]), got {}", f.size()));
    }
    Eigen::Matrix<double, 3, 4> M;
    for (int k = 0; k < 12; ++k) M(k / 4, k % 4) = ParseFinite(f[k], path, n, "pose matrix entry");
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = CheckedRotation(M.leftCols<3>(), path, n, f[0].column);
    T.translation() = M.col(3);
    poses.push_back(T);
  }
  return poses;
}

std::vector<int64_t> ReadKittiTimes(std::istream& in, const std::string& path) {
  std::vector<int64_t> times;
  LineReader reader(in, path);
  std::string line;
  int64_t blank_line = -1;
  while (reader.Next(&line)) {
    const int64_t n = reader.line_number();
    const std::vector<Field> f = SplitFields(line, " \t");
    if (f.empty()) {
      if (blank_line < 0) blank_line = n;
      continue;
    }
    if (blank_line >= 0) throw InputError(InputLocation::Line(path, blank_line), "blank line inside times file");
    if (f.size() != 1) {
      throw InputError(InputLocation::Line(path, n, f[1].column),
                       fmt::format("expected one time in seconds, got {} fields", f.size()));
    }
    const int64_t t_ns = ParseSecondsField(f[0], path, n);
    CheckNotDecreasing(times.empty() ? 0 : times.back(), t_ns, !times.empty(), path, n, f[0].column);
    times.push_back(t_ns);
  }
  return times;
}

Trajectory MakeKittiTrajectory(const std::vector<Eigen::Isometry3d>& poses, const std::string& poses_path,
                               const std::optional<std::vector<int64_t>>& times_ns, const std::string& times_path) {
  if (times_ns && times_ns->size() != poses.size()) {
    throw InputError(InputLocation::File(times_path),
                     fmt::format("{} times for {} poses in {}", times_ns->size(), poses.size(), poses_path));
  }
  Trajectory trajectory;
  trajectory.source = poses_path;
  trajectory.has_times = times_ns.has_value();
  trajectory.poses.resize(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    trajectory.poses[i].t_ns = times_ns ? (*times_ns)[i] : static_cast<int64_t>(i);
    trajectory.poses[i].T_world_frame = poses[i];
  }
  return trajectory;
}

Trajectory ReadKittiTrajectory(const std::filesystem::path& poses_path,
                               const std::optional<std::filesystem::path>& times_path) {
  std::ifstream in(poses_path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(poses_path.string()), "cannot open poses file");
  const std::vector<Eigen::Isometry3d> poses = ReadKittiPoses(in, poses_path.string());
  std::optional<std::vector<int64_t>> times;
  if (times_path) {
    std::ifstream tin(*times_path, std::ios::binary);
    if (!tin) throw InputError(InputLocation::File(times_path->string()), "cannot open times file");
    times = ReadKittiTimes(tin, times_path->string());
  }
  return MakeKittiTrajectory(poses, poses_path.string(), times, times_path ? times_path->string() : "");
}

void WriteKittiPoses(std::ostream& out, const Trajectory& trajectory) {
  for (const StampedPose& p : trajectory.poses) {
    const Eigen::Matrix<double, 3, 4> M = p.T_world_frame.matrix().topRows<3>();
    for (int k = 0; k < 12; ++k) out << (k == 0 ? "" : " ") << fmt::format("{:.17g}", M(k / 4, k % 4));
    out << '\n';
  }
}

void WriteKittiPoses(const std::filesystem::path& path, const Trajectory& trajectory) {
  WriteStreamChecked(path, [&](std::ostream& out) { WriteKittiPoses(out, trajectory); });
}

}  // namespace rs
