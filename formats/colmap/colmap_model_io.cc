// A model folder: the three files in one format, and their agreement with each other.
#include <fstream>
#include <sstream>
#include <unordered_map>

#include <fmt/format.h>

#include "formats/checked_file.h"
#include "formats/colmap/colmap_io.h"
#include "formats/input_error.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open COLMAP model file");
  std::ostringstream s;
  s << in.rdbuf();
  return std::move(s).str();
}

// Every reference resolves, and a 2D point and the track element naming it point at each other.
void CheckConsistent(const ColmapModel& m, const fs::path& dir, const char* images_file, const char* points_file) {
  const std::string images_path = (dir / images_file).string(), points_path = (dir / points_file).string();
  std::unordered_map<uint32_t, const ColmapImage*> images;
  std::unordered_map<uint64_t, const ColmapPoint3D*> points;
  for (const auto& c : m.cameras)
    if (std::count_if(m.cameras.begin(), m.cameras.end(), [&](const auto& o) { return o.id == c.id; }) > 1)
      throw InputError(InputLocation::File((dir / (fs::path(images_file).extension() == ".bin" ? "cameras.bin" : "cameras.txt")).string()),
                       fmt::format("camera {} listed twice", c.id));
  for (const auto& im : m.images) {
    if (!images.emplace(im.id, &im).second)
      throw InputError(InputLocation::File(images_path), fmt::format("image {} listed twice", im.id));
    if (!m.FindCamera(im.camera_id))
      throw InputError(InputLocation::File(images_path),
                       fmt::format("image {} ({}) names camera {}, which is not in the model", im.id, im.name, im.camera_id));
  }
  for (const auto& p : m.points)
    if (!points.emplace(p.id, &p).second)
      throw InputError(InputLocation::File(points_path), fmt::format("3D point {} listed twice", p.id));
  for (const auto& p : m.points)
    for (const auto& e : p.track) {
      const auto it = images.find(e.image_id);
      if (it == images.end() || e.point2d_idx >= it->second->points2d.size() ||
          it->second->points2d[e.point2d_idx].point3d_id != p.id)
        throw InputError(InputLocation::File(points_path),
                         fmt::format("3D point {}: track element (image {}, 2D point {}) does not name this point", p.id,
                                     e.image_id, e.point2d_idx));
    }
  for (const auto& im : m.images)
    for (size_t i = 0; i < im.points2d.size(); ++i) {
      const uint64_t id = im.points2d[i].point3d_id;
      if (id == kColmapNoPoint3D) continue;
      const auto it = points.find(id);
      const ColmapTrackElement self{im.id, static_cast<uint32_t>(i)};
      if (it == points.end() ||
          std::find(it->second->track.begin(), it->second->track.end(), self) == it->second->track.end())
        throw InputError(InputLocation::File(images_path),
                         fmt::format("image {} 2D point {} names 3D point {}, whose track does not list it", im.id, i, id));
    }
}

}  // namespace

ColmapModel ReadColmapModel(const fs::path& dir) {
  ColmapModel m;
  if (fs::exists(dir / "cameras.bin")) {
    auto read = [&](const char* name, auto parse) { return parse(Slurp(dir / name), (dir / name).string()); };
    m.cameras = read("cameras.bin", ReadColmapCamerasBinary);
    m.images = read("images.bin", ReadColmapImagesBinary);
    m.points = read("points3D.bin", ReadColmapPointsBinary);
    CheckConsistent(m, dir, "images.bin", "points3D.bin");
    return m;
  }
  if (!fs::exists(dir / "cameras.txt"))
    throw InputError(InputLocation::File(dir.string()), "no COLMAP model here (neither cameras.bin nor cameras.txt)");
  auto read = [&](const char* name, auto parse) {
    std::ifstream in(dir / name, std::ios::binary);
    if (!in) throw InputError(InputLocation::File((dir / name).string()), "cannot open COLMAP model file");
    return parse(in, (dir / name).string());
  };
  m.cameras = read("cameras.txt", ReadColmapCamerasText);
  m.images = read("images.txt", ReadColmapImagesText);
  m.points = read("points3D.txt", ReadColmapPointsText);
  CheckConsistent(m, dir, "images.txt", "points3D.txt");
  return m;
}

void WriteColmapModel(const fs::path& dir, const ColmapModel& m, ColmapFormat format) {
  fs::create_directories(dir);
  if (format == ColmapFormat::kBinary) {
    WriteFileChecked(dir / "cameras.bin", ColmapCamerasBinary(m.cameras));
    WriteFileChecked(dir / "images.bin", ColmapImagesBinary(m.images));
    WriteFileChecked(dir / "points3D.bin", ColmapPointsBinary(m.points));
    return;
  }
  WriteStreamChecked(dir / "cameras.txt", [&](std::ostream& o) { WriteColmapCamerasText(o, m.cameras); });
  WriteStreamChecked(dir / "images.txt", [&](std::ostream& o) { WriteColmapImagesText(o, m.images); });
  WriteStreamChecked(dir / "points3D.txt", [&](std::ostream& o) { WriteColmapPointsText(o, m.points); });
}

}  // namespace rs
