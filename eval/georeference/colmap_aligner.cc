#include "eval/georeference/colmap_aligner.h"

#include <fmt/format.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "formats/checked_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

std::string ImageName(int64_t t_ns) { return fmt::format("{}.png", t_ns); }

void WriteModel(const fs::path& dir, const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& poses) {
  fs::create_directories(dir);
  // The aligner uses image centres only: the camera's intrinsics do not matter.
  WriteFileChecked(dir / "cameras.txt", "1 PINHOLE 1280 720 1000 1000 640 360\n");
  std::ostringstream images;
  int id = 1;
  for (const auto& [t_ns, T_w_c] : poses) {
    const Eigen::Isometry3d T_c_w = T_w_c.inverse();
    const Eigen::Quaterniond q(T_c_w.linear());
    const Eigen::Vector3d t = T_c_w.translation();
    images << fmt::format("{} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} 1 {}\n\n", id++, q.w(), q.x(),
                          q.y(), q.z(), t.x(), t.y(), t.z(), ImageName(t_ns));
  }
  WriteFileChecked(dir / "images.txt", images.view());
  WriteFileChecked(dir / "points3D.txt", "");
}

std::map<int64_t, Eigen::Isometry3d> ReadImages(const fs::path& images_txt) {
  std::map<int64_t, Eigen::Isometry3d> out;
  std::ifstream in(images_txt);
  std::string line;
  bool pose_line = true;
  while (std::getline(in, line)) {
    if (line.empty() && pose_line) continue;
    if (!line.empty() && line[0] == '#') continue;
    if (pose_line) {
      std::istringstream f(line);
      int id, cam;
      double qw, qx, qy, qz, tx, ty, tz;
      std::string name;
      if (f >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> cam >> name) {
        Eigen::Isometry3d T_c_w = Eigen::Isometry3d::Identity();
        T_c_w.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
        T_c_w.translation() = Eigen::Vector3d(tx, ty, tz);
        out[std::stoll(name.substr(0, name.find('.')))] = T_c_w.inverse();
      }
    }
    pose_line = !pose_line;  // every image has a second line (its 2D points, here empty)
  }
  return out;
}

}  // namespace

std::optional<std::map<int64_t, Eigen::Isometry3d>> AlignWithColmap(
    const std::vector<std::pair<int64_t, Eigen::Isometry3d>>& poses, const std::map<int64_t, Eigen::Vector3d>& refs,
    double max_error_m, const fs::path& work, std::string* why) {
  if (std::system("command -v colmap >/dev/null 2>&1") != 0) {
    *why = "colmap not installed";
    return std::nullopt;
  }
  fs::remove_all(work);
  WriteModel(work / "model", poses);
  std::ostringstream ref;
  for (const auto& [t_ns, p] : refs) ref << fmt::format("{} {:.6f} {:.6f} {:.6f}\n", ImageName(t_ns), p.x(), p.y(), p.z());
  WriteFileChecked(work / "ref_images.txt", ref.view());
  fs::create_directories(work / "aligned");
  fs::create_directories(work / "aligned_txt");
  const std::string cmd = fmt::format(
      "colmap model_aligner --input_path '{0}/model' --output_path '{0}/aligned' --ref_images_path "
      "'{0}/ref_images.txt' --ref_is_gps 0 --alignment_type custom --robust_alignment 1 "
      "--robust_alignment_max_error {1} > '{0}/log.txt' 2>&1 && colmap model_converter --input_path '{0}/aligned' "
      "--output_path '{0}/aligned_txt' --output_type TXT >> '{0}/log.txt' 2>&1",
      work.string(), max_error_m);
  if (std::system(cmd.c_str()) != 0) {
    *why = "colmap model_aligner failed: see " + (work / "log.txt").string();
    return std::nullopt;
  }
  *why = fmt::format("colmap model_aligner --ref_is_gps 0 --alignment_type custom --robust_alignment 1 "
                     "--robust_alignment_max_error {} (scale estimated, its default)",
                     max_error_m);
  return ReadImages(work / "aligned_txt" / "images.txt");
}

}  // namespace rs
