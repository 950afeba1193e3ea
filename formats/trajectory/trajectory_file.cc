#include "formats/trajectory/trajectory_file.h"

#include <fstream>

#include <fmt/format.h>

#include "formats/input_error.h"
#include "formats/trajectory/euroc_trajectory.h"
#include "formats/trajectory/kitti_poses.h"
#include "formats/trajectory/trajectory_text.h"
#include "formats/trajectory/tum_trajectory.h"

namespace rs {

using namespace trajectory_text;

std::optional<TrajectoryFormat> ParseTrajectoryFormat(std::string_view name) {
  if (name == "tum") return TrajectoryFormat::kTum;
  if (name == "kitti") return TrajectoryFormat::kKitti;
  if (name == "euroc" || name == "asl") return TrajectoryFormat::kEuroc;
  return std::nullopt;
}

const char* TrajectoryFormatName(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum: return "tum";
    case TrajectoryFormat::kKitti: return "kitti";
    case TrajectoryFormat::kEuroc: return "euroc";
  }
  return "?";
}

TrajectoryFormat DetectTrajectoryFormat(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open trajectory file");
  LineReader reader(in, path.string());
  std::string line;
  while (reader.Next(&line)) {
    if (IsBlankOrComment(line)) continue;
    const InputLocation where = InputLocation::Line(path.string(), reader.line_number());
    if (line.find(',') != std::string::npos) {
      const std::vector<Field> f = SplitCsv(line);
      const bool integer_time =
          !f[0].text.empty() && f[0].text.find_first_not_of("0123456789") == std::string_view::npos;
      if (f.size() >= 8 && integer_time) return TrajectoryFormat::kEuroc;
      if (f.size() == 8) return TrajectoryFormat::kTum;
      throw InputError(where, fmt::format("cannot tell the trajectory format: {} comma-separated fields", f.size()));
    }
    const size_t n = SplitFields(line, " \t").size();
    if (n == 12) return TrajectoryFormat::kKitti;
    if (n == 8) return TrajectoryFormat::kTum;
    throw InputError(where, fmt::format("cannot tell the trajectory format: {} fields (TUM has 8, KITTI 12)", n));
  }
  throw InputError(InputLocation::File(path.string()), "no poses in trajectory file");
}

Trajectory ReadTrajectory(const std::filesystem::path& path, std::optional<TrajectoryFormat> format,
                          const std::optional<std::filesystem::path>& kitti_times) {
  switch (format ? *format : DetectTrajectoryFormat(path)) {
    case TrajectoryFormat::kTum: return ReadTumTrajectory(path);
    case TrajectoryFormat::kEuroc: return ReadEurocTrajectory(path);
    case TrajectoryFormat::kKitti: return ReadKittiTrajectory(path, kitti_times);
  }
  throw InputError(InputLocation::File(path.string()), "unknown trajectory format");
}

}  // namespace rs
