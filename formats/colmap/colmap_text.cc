// COLMAP's text model files: '#' comment lines, fields separated by spaces.
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <istream>
#include <ostream>

#include <fmt/format.h>

#include "formats/colmap/colmap_io.h"
#include "formats/input_error.h"

namespace rs {
namespace {

constexpr size_t kMaxLineBytes = 64 << 20;  // images.txt lines hold every 2D point of an image

struct Token {
  std::string_view text;
  int64_t column = 1;  // 1-based
};

// Reads lines, counting them, and splits them into space-separated tokens.
class TextReader {
 public:
  TextReader(std::istream& in, std::string path) : in_(in), path_(std::move(path)) {}

  // Next line that is not blank or a comment; false at the end.
  bool NextRecord() {
    while (NextLine())
      if (!IsBlankOrComment()) return true;
    return false;
  }
  // The very next line (may be blank); false at the end.
  bool NextLine() {
    if (!std::getline(in_, line_)) return false;
    ++line_number_;
    if (!line_.empty() && line_.back() == '\r') line_.pop_back();
    if (line_.size() > kMaxLineBytes) Fail(-1, "line longer than 64 MiB");
    Split();
    return true;
  }
  const std::vector<Token>& tokens() const { return tokens_; }

  [[noreturn]] void Fail(int64_t column, const std::string& message) const {
    throw InputError(InputLocation::Line(path_, line_number_, column), message);
  }
  void ExpectAtLeast(size_t n, const char* what) const {
    if (tokens_.size() < n) Fail(-1, fmt::format("expected {}, got {} field(s)", what, tokens_.size()));
  }
  template <typename Int>
  Int ParseInt(size_t i, const char* name) const {
    const Token& t = tokens_.at(i);
    Int v{};
    const auto [end, ec] = std::from_chars(t.text.data(), t.text.data() + t.text.size(), v);
    if (ec != std::errc() || end != t.text.data() + t.text.size())
      Fail(t.column, fmt::format("{} '{}' is not an integer in range", name, t.text));
    return v;
  }
  double ParseDouble(size_t i, const char* name) const {
    const Token& t = tokens_.at(i);
    double v = 0;
    const auto [end, ec] = std::from_chars(t.text.data(), t.text.data() + t.text.size(), v);
    if (ec != std::errc() || end != t.text.data() + t.text.size() || !std::isfinite(v))
      Fail(t.column, fmt::format("{} '{}' is not a finite number", name, t.text));
    return v;
  }

 private:
  bool IsBlankOrComment() const { return tokens_.empty() || tokens_[0].text[0] == '#'; }
  void Split() {
    tokens_.clear();
    size_t i = 0;
    while (i < line_.size()) {
      while (i < line_.size() && (line_[i] == ' ' || line_[i] == '\t')) ++i;
      const size_t start = i;
      while (i < line_.size() && line_[i] != ' ' && line_[i] != '\t') ++i;
      if (i > start) tokens_.push_back({std::string_view(line_).substr(start, i - start), int64_t(start) + 1});
    }
  }

  std::istream& in_;
  std::string path_;
  std::string line_;
  int64_t line_number_ = 0;
  std::vector<Token> tokens_;
};

// COLMAP writes -1 for "no 3D point" in images.txt.
uint64_t ParsePoint3DId(const TextReader& r, size_t i) {
  if (r.tokens().at(i).text == "-1") return kColmapNoPoint3D;
  return r.ParseInt<uint64_t>(i, "POINT3D_ID");
}

}  // namespace

std::vector<ColmapCamera> ReadColmapCamerasText(std::istream& in, const std::string& path) {
  std::vector<ColmapCamera> cameras;
  TextReader r(in, path);
  while (r.NextRecord()) {
    r.ExpectAtLeast(4, "CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    ColmapCamera c;
    c.id = r.ParseInt<uint32_t>(0, "CAMERA_ID");
    c.model = std::string(r.tokens()[1].text);
    const auto model = FindColmapCameraModel(c.model);
    if (!model) r.Fail(r.tokens()[1].column, fmt::format("unknown camera model '{}'", c.model));
    c.width = r.ParseInt<uint64_t>(2, "WIDTH");
    c.height = r.ParseInt<uint64_t>(3, "HEIGHT");
    if (r.tokens().size() != 4 + size_t(model->num_params))
      r.Fail(-1, fmt::format("{} takes {} parameters, got {}", c.model, model->num_params, r.tokens().size() - 4));
    for (size_t i = 4; i < r.tokens().size(); ++i) c.params.push_back(r.ParseDouble(i, "camera parameter"));
    cameras.push_back(std::move(c));
  }
  return cameras;
}

std::vector<ColmapImage> ReadColmapImagesText(std::istream& in, const std::string& path) {
  std::vector<ColmapImage> images;
  TextReader r(in, path);
  while (r.NextRecord()) {
    r.ExpectAtLeast(10, "IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    ColmapImage im;
    im.id = r.ParseInt<uint32_t>(0, "IMAGE_ID");
    double v[7];
    static const char* kNames[7] = {"QW", "QX", "QY", "QZ", "TX", "TY", "TZ"};
    for (int k = 0; k < 7; ++k) v[k] = r.ParseDouble(1 + k, kNames[k]);
    const Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
    if (std::abs(q.norm() - 1) > 1e-3) r.Fail(r.tokens()[1].column, fmt::format("quaternion norm {} is not 1", q.norm()));
    im.q_cam_world = q.normalized();
    im.t_cam_world = Eigen::Vector3d(v[4], v[5], v[6]);
    im.camera_id = r.ParseInt<uint32_t>(8, "CAMERA_ID");
    if (r.tokens().size() != 10) r.Fail(r.tokens()[10].column, "image names with spaces are not supported");
    im.name = std::string(r.tokens()[9].text);
    // The 2D points follow on the next line (blank when there are none; COLMAP accepts it missing at the end).
    if (r.NextLine()) {
      if (r.tokens().size() % 3 != 0) r.Fail(-1, fmt::format("expected X Y POINT3D_ID triplets, got {} fields", r.tokens().size()));
      for (size_t i = 0; i < r.tokens().size(); i += 3)
        im.points2d.push_back({r.ParseDouble(i, "X"), r.ParseDouble(i + 1, "Y"), ParsePoint3DId(r, i + 2)});
    }
    images.push_back(std::move(im));
  }
  return images;
}

std::vector<ColmapPoint3D> ReadColmapPointsText(std::istream& in, const std::string& path) {
  std::vector<ColmapPoint3D> points;
  TextReader r(in, path);
  while (r.NextRecord()) {
    r.ExpectAtLeast(8, "POINT3D_ID X Y Z R G B ERROR TRACK[]");
    ColmapPoint3D p;
    p.id = r.ParseInt<uint64_t>(0, "POINT3D_ID");
    p.xyz = Eigen::Vector3d(r.ParseDouble(1, "X"), r.ParseDouble(2, "Y"), r.ParseDouble(3, "Z"));
    for (int k = 0; k < 3; ++k) p.rgb[k] = r.ParseInt<uint8_t>(4 + k, "colour");
    p.error = r.ParseDouble(7, "ERROR");
    if ((r.tokens().size() - 8) % 2 != 0) r.Fail(-1, "track must be IMAGE_ID POINT2D_IDX pairs");
    for (size_t i = 8; i < r.tokens().size(); i += 2)
      p.track.push_back({r.ParseInt<uint32_t>(i, "IMAGE_ID"), r.ParseInt<uint32_t>(i + 1, "POINT2D_IDX")});
    points.push_back(std::move(p));
  }
  return points;
}

void WriteColmapCamerasText(std::ostream& out, const std::vector<ColmapCamera>& cameras) {
  out << "# Camera list with one line of data per camera:\n"
         "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      << fmt::format("# Number of cameras: {}\n", cameras.size());
  for (const auto& c : cameras) {
    out << fmt::format("{} {} {} {}", c.id, c.model, c.width, c.height);
    for (double p : c.params) out << fmt::format(" {:.17g}", p);
    out << '\n';
  }
}

void WriteColmapImagesText(std::ostream& out, const std::vector<ColmapImage>& images) {
  size_t observations = 0;
  for (const auto& im : images)
    for (const auto& p : im.points2d) observations += p.point3d_id != kColmapNoPoint3D;
  out << "# Image list with two lines of data per image:\n"
         "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
         "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      << fmt::format("# Number of images: {}, mean observations per image: {}\n", images.size(),
                     images.empty() ? 0.0 : double(observations) / images.size());
  for (const auto& im : images) {
    const auto& q = im.q_cam_world;
    const auto& t = im.t_cam_world;
    out << fmt::format("{} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {} {}\n", im.id, q.w(), q.x(), q.y(),
                       q.z(), t.x(), t.y(), t.z(), im.camera_id, im.name);
    for (size_t i = 0; i < im.points2d.size(); ++i) {
      const auto& p = im.points2d[i];
      if (i) out << ' ';
      if (p.point3d_id == kColmapNoPoint3D)
        out << fmt::format("{:.17g} {:.17g} -1", p.x, p.y);
      else
        out << fmt::format("{:.17g} {:.17g} {}", p.x, p.y, p.point3d_id);
    }
    out << '\n';
  }
}

void WriteColmapPointsText(std::ostream& out, const std::vector<ColmapPoint3D>& points) {
  size_t track = 0;
  for (const auto& p : points) track += p.track.size();
  out << "# 3D point list with one line of data per point:\n"
         "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
      << fmt::format("# Number of points: {}, mean track length: {}\n", points.size(),
                     points.empty() ? 0.0 : double(track) / points.size());
  for (const auto& p : points) {
    out << fmt::format("{} {:.17g} {:.17g} {:.17g} {} {} {} {:.17g}", p.id, p.xyz.x(), p.xyz.y(), p.xyz.z(), p.rgb[0],
                       p.rgb[1], p.rgb[2], p.error);
    for (const auto& e : p.track) out << fmt::format(" {} {}", e.image_id, e.point2d_idx);
    out << '\n';
  }
}

}  // namespace rs
