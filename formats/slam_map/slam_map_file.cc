#include "formats/slam_map/slam_map_file.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "formats/checked_file.h"
#include "formats/input_error.h"
#include "formats/trajectory/trajectory_text.h"

namespace rs {
namespace fs = std::filesystem;
using namespace trajectory_text;
namespace {

constexpr const char* kFormat = "roadsurvey-slam-map-v1";

std::ifstream OpenOrThrow(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open SLAM map file");
  return in;
}

int ParseInt(const Field& f, const std::string& path, int64_t line, const char* what) {
  const double v = ParseFinite(f, path, line, what);
  if (v != std::floor(v) || std::abs(v) > 2e9)
    throw InputError(InputLocation::Line(path, line, f.column), fmt::format("{} must be an integer", what));
  return static_cast<int>(v);
}

int64_t ParseInt64(const Field& f, const std::string& path, int64_t line, const char* what) {
  int64_t v = 0;
  const auto [end, ec] = std::from_chars(f.text.data(), f.text.data() + f.text.size(), v);
  if (ec != std::errc() || end != f.text.data() + f.text.size())
    throw InputError(InputLocation::Line(path, line, f.column), fmt::format("{} must be an integer", what));
  return v;
}

void ReadHeader(const fs::path& path, SlamMapFile* map) {
  std::ifstream in = OpenOrThrow(path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
    if (j.value("format", "") != kFormat)
      throw InputError(InputLocation::File(path.string()),
                       fmt::format("not a SLAM map header (format is not \"{}\")", kFormat));
    const auto& c = j.at("camera");
    map->camera = {c.at("width").get<int>(),  c.at("height").get<int>(), c.at("fx").get<double>(),
                   c.at("fy").get<double>(),  c.at("cx").get<double>(),  c.at("cy").get<double>(),
                   c.at("baseline_m").get<double>()};
    map->scale_factor = j.at("scale_factor").get<double>();
    map->pyramid_levels = j.at("pyramid_levels").get<int>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(InputLocation::File(path.string()), std::string("bad SLAM map header: ") + e.what());
  }
  if (!(map->camera.fx > 0 && map->camera.fy > 0 && map->camera.baseline_m > 0 && map->scale_factor > 1 &&
        map->pyramid_levels >= 1))
    throw InputError(InputLocation::File(path.string()),
                     "SLAM map header needs fx, fy, baseline_m > 0, scale_factor > 1 and pyramid_levels >= 1");
}

void ReadKeyframes(const fs::path& path, SlamMapFile* map) {
  std::ifstream in = OpenOrThrow(path);
  LineReader reader(in, path.string());
  std::string line;
  while (reader.Next(&line)) {
    if (IsBlankOrComment(line)) continue;
    const int64_t n = reader.line_number();
    const auto f = SplitFields(line, " \t");
    if (f.size() != 10)
      throw InputError(InputLocation::Line(path.string(), n),
                       fmt::format("expected 10 fields (id t_ns segment tx ty tz qx qy qz qw), got {}", f.size()));
    SlamMapKeyframe k;
    k.id = ParseInt(f[0], path.string(), n, "keyframe id");
    k.t_ns = ParseInt64(f[1], path.string(), n, "t_ns");
    k.segment = ParseInt(f[2], path.string(), n, "segment");
    double v[7];
    static const char* kNames[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    for (int i = 0; i < 7; ++i) v[i] = ParseFinite(f[i + 3], path.string(), n, kNames[i]);
    k.T_cam_world.linear() = CheckedQuaternion(v[6], v[3], v[4], v[5], path.string(), n, f[6].column).toRotationMatrix();
    k.T_cam_world.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    if (map->FindKeyframe(k.id))
      throw InputError(InputLocation::Line(path.string(), n, f[0].column), fmt::format("keyframe {} repeated", k.id));
    map->keyframes.push_back(k);
  }
}

void ReadPoints(const fs::path& path, SlamMapFile* map) {
  std::ifstream in = OpenOrThrow(path);
  LineReader reader(in, path.string());
  std::string line;
  const std::string p = path.string();
  while (reader.Next(&line)) {
    if (IsBlankOrComment(line)) continue;
    const int64_t n = reader.line_number();
    const auto f = SplitFields(line, " \t");
    if (f.size() < 5) throw InputError(InputLocation::Line(p, n), "expected id x y z n, then n observations");
    SlamMapPoint pt;
    pt.id = ParseInt(f[0], p, n, "point id");
    pt.p_world = {ParseFinite(f[1], p, n, "x"), ParseFinite(f[2], p, n, "y"), ParseFinite(f[3], p, n, "z")};
    const int count = ParseInt(f[4], p, n, "observation count");
    if (count < 0 || f.size() != 5 + 5 * static_cast<size_t>(count))
      throw InputError(InputLocation::Line(p, n, f[4].column),
                       fmt::format("{} observations need {} fields, the line has {}", count, 5 + 5 * count, f.size()));
    for (int i = 0; i < count; ++i) {
      const Field* o = &f[5 + 5 * i];
      SlamMapObservation obs;
      obs.keyframe = ParseInt(o[0], p, n, "observation keyframe");
      obs.u_px = ParseFinite(o[1], p, n, "u");
      obs.v_px = ParseFinite(o[2], p, n, "v");
      obs.level = ParseInt(o[3], p, n, "level");
      obs.u_right_px = ParseFinite(o[4], p, n, "u_right");
      if (!map->FindKeyframe(obs.keyframe))
        throw InputError(InputLocation::Line(p, n, o[0].column),
                         fmt::format("observation of keyframe {}, which keyframes.txt does not list", obs.keyframe));
      if (obs.level < 0 || obs.level >= map->pyramid_levels)
        throw InputError(InputLocation::Line(p, n, o[3].column),
                         fmt::format("level {} outside the pyramid (0..{})", obs.level, map->pyramid_levels - 1));
      pt.observations.push_back(obs);
    }
    map->points.push_back(std::move(pt));
  }
}

}  // namespace

double SlamMapFile::LevelSigmaPx(int level) const { return std::pow(scale_factor, level); }

const SlamMapKeyframe* SlamMapFile::FindKeyframe(int id) const {
  // Keyframe ids grow with time in the files we write; a linear scan keeps foreign files working.
  for (const auto& k : keyframes)
    if (k.id == id) return &k;
  return nullptr;
}

void WriteSlamMap(const fs::path& dir, const SlamMapFile& map) {
  fs::create_directories(dir);
  const auto& c = map.camera;
  const nlohmann::json header = {
      {"format", kFormat},
      {"camera",
       {{"width", c.width}, {"height", c.height}, {"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy},
        {"baseline_m", c.baseline_m}}},
      {"scale_factor", map.scale_factor},
      {"pyramid_levels", map.pyramid_levels}};
  WriteFileChecked(dir / "map.json", header.dump(2) + "\n");
  WriteStreamChecked(dir / "keyframes.txt", [&](std::ostream& out) {
    out << "# keyframe_id t_ns segment  T_cam_world (world -> left camera): tx ty tz qx qy qz qw\n";
    for (const auto& k : map.keyframes) {
      const Eigen::Quaterniond q(k.T_cam_world.linear());
      const Eigen::Vector3d t = k.T_cam_world.translation();
      out << fmt::format("{} {} {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}\n", k.id, k.t_ns, k.segment,
                         t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    }
  });
  WriteStreamChecked(dir / "points.txt", [&](std::ostream& out) {
    out << "# point_id x y z n  then n x (keyframe_id u_px v_px level u_right_px), left rectified image; "
           "u_right_px < 0: no stereo match\n";
    for (const auto& pt : map.points) {
      out << fmt::format("{} {:.9g} {:.9g} {:.9g} {}", pt.id, pt.p_world.x(), pt.p_world.y(), pt.p_world.z(),
                         pt.observations.size());
      for (const auto& o : pt.observations)
        out << fmt::format(" {} {:.3f} {:.3f} {} {:.3f}", o.keyframe, o.u_px, o.v_px, o.level,
                           o.u_right_px < 0 ? -1.0 : o.u_right_px);
      out << '\n';
    }
  });
}

SlamMapFile ReadSlamMap(const fs::path& dir) {
  SlamMapFile map;
  ReadHeader(dir / "map.json", &map);
  ReadKeyframes(dir / "keyframes.txt", &map);
  ReadPoints(dir / "points.txt", &map);
  return map;
}

}  // namespace rs
