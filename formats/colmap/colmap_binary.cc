// COLMAP's binary model files (src/base/reconstruction.cc, WriteBinary/ReadBinary): little-endian
// integers and IEEE doubles, names NUL-terminated.
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "formats/colmap/colmap_io.h"
#include "formats/input_error.h"

namespace rs {
namespace {

static_assert(sizeof(double) == 8);

// Reads little-endian values from a byte buffer, failing with the byte offset.
class ByteReader {
 public:
  ByteReader(std::string_view bytes, std::string path) : bytes_(bytes), path_(std::move(path)) {}

  template <typename T>
  T Read(const char* what) {
    Need(sizeof(T), what);
    T v;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));  // the files are little-endian, as is every target we build for
    pos_ += sizeof(T);
    return v;
  }
  double ReadFinite(const char* what) {
    const size_t at = pos_;
    const double v = Read<double>(what);
    if (!std::isfinite(v)) Fail(at, fmt::format("{} is not finite", what));
    return v;
  }
  // A count of records of at least `min_record_bytes` each: more than the bytes left can hold is an
  // error before anything is allocated.
  uint64_t ReadCount(const char* what, size_t min_record_bytes) {
    const size_t at = pos_;
    const uint64_t n = Read<uint64_t>(what);
    if (min_record_bytes > 0 && n > (bytes_.size() - pos_) / min_record_bytes)
      Fail(at, fmt::format("{} {} does not fit in the {} bytes left", what, n, bytes_.size() - pos_));
    return n;
  }
  std::string ReadName() {
    const size_t end = bytes_.find('\0', pos_);
    if (end == std::string_view::npos) Fail(pos_, "image name without terminating NUL");
    std::string s(bytes_.substr(pos_, end - pos_));
    pos_ = end + 1;
    return s;
  }
  void ExpectEnd() const {
    if (pos_ != bytes_.size()) Fail(pos_, fmt::format("{} unexpected bytes after the last record", bytes_.size() - pos_));
  }
  size_t pos() const { return pos_; }
  [[noreturn]] void Fail(size_t at, const std::string& message) const {
    throw InputError(InputLocation::Byte(path_, static_cast<int64_t>(at)), message);
  }

 private:
  void Need(size_t n, const char* what) const {
    if (bytes_.size() - pos_ < n) Fail(pos_, fmt::format("file ends inside {}", what));
  }
  std::string_view bytes_;
  std::string path_;
  size_t pos_ = 0;
};

template <typename T>
void Put(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

}  // namespace

std::vector<ColmapCamera> ReadColmapCamerasBinary(std::string_view bytes, const std::string& path) {
  ByteReader r(bytes, path);
  const uint64_t n = r.ReadCount("camera count", 4 + 4 + 8 + 8);
  std::vector<ColmapCamera> cameras;
  cameras.reserve(n);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapCamera c;
    c.id = r.Read<uint32_t>("camera id");
    const size_t at = r.pos();
    const auto model = FindColmapCameraModel(r.Read<int32_t>("camera model"));
    if (!model) r.Fail(at, "unknown camera model id");
    c.model = model->name;
    c.width = r.Read<uint64_t>("width");
    c.height = r.Read<uint64_t>("height");
    for (int k = 0; k < model->num_params; ++k) c.params.push_back(r.ReadFinite("camera parameter"));
    cameras.push_back(std::move(c));
  }
  r.ExpectEnd();
  return cameras;
}

std::vector<ColmapImage> ReadColmapImagesBinary(std::string_view bytes, const std::string& path) {
  ByteReader r(bytes, path);
  const uint64_t n = r.ReadCount("image count", 4 + 7 * 8 + 4 + 1 + 8);
  std::vector<ColmapImage> images;
  images.reserve(n);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapImage im;
    im.id = r.Read<uint32_t>("image id");
    const size_t at_q = r.pos();
    double q[4];
    for (double& v : q) v = r.ReadFinite("quaternion");
    const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
    if (std::abs(quat.norm() - 1) > 1e-3) r.Fail(at_q, fmt::format("quaternion norm {} is not 1", quat.norm()));
    im.q_cam_world = quat.normalized();
    for (int k = 0; k < 3; ++k) im.t_cam_world[k] = r.ReadFinite("translation");
    im.camera_id = r.Read<uint32_t>("camera id");
    im.name = r.ReadName();
    const uint64_t m = r.ReadCount("2D point count", 8 + 8 + 8);
    im.points2d.reserve(m);
    for (uint64_t k = 0; k < m; ++k) {
      ColmapPoint2D p;
      p.x = r.ReadFinite("2D point x");
      p.y = r.ReadFinite("2D point y");
      p.point3d_id = r.Read<uint64_t>("3D point id");
      im.points2d.push_back(p);
    }
    images.push_back(std::move(im));
  }
  r.ExpectEnd();
  return images;
}

std::vector<ColmapPoint3D> ReadColmapPointsBinary(std::string_view bytes, const std::string& path) {
  ByteReader r(bytes, path);
  const uint64_t n = r.ReadCount("point count", 8 + 3 * 8 + 3 + 8 + 8);
  std::vector<ColmapPoint3D> points;
  points.reserve(n);
  for (uint64_t i = 0; i < n; ++i) {
    ColmapPoint3D p;
    p.id = r.Read<uint64_t>("point id");
    for (int k = 0; k < 3; ++k) p.xyz[k] = r.ReadFinite("point coordinate");
    for (int k = 0; k < 3; ++k) p.rgb[k] = r.Read<uint8_t>("colour");
    p.error = r.Read<double>("error");  // COLMAP may store nan/-1 here for points it did not score
    const uint64_t m = r.ReadCount("track length", 4 + 4);
    p.track.reserve(m);
    for (uint64_t k = 0; k < m; ++k) {
      ColmapTrackElement e;
      e.image_id = r.Read<uint32_t>("track image id");
      e.point2d_idx = r.Read<uint32_t>("track 2D point index");
      p.track.push_back(e);
    }
    points.push_back(std::move(p));
  }
  r.ExpectEnd();
  return points;
}

std::string ColmapCamerasBinary(const std::vector<ColmapCamera>& cameras) {
  std::string out;
  Put<uint64_t>(out, cameras.size());
  for (const auto& c : cameras) {
    const auto model = FindColmapCameraModel(c.model);
    if (!model || model->num_params != static_cast<int>(c.params.size()))
      throw std::logic_error(fmt::format("camera {}: model {} with {} parameters", c.id, c.model, c.params.size()));
    Put<uint32_t>(out, c.id);
    Put<int32_t>(out, model->id);
    Put<uint64_t>(out, c.width);
    Put<uint64_t>(out, c.height);
    for (double p : c.params) Put<double>(out, p);
  }
  return out;
}

std::string ColmapImagesBinary(const std::vector<ColmapImage>& images) {
  std::string out;
  Put<uint64_t>(out, images.size());
  for (const auto& im : images) {
    Put<uint32_t>(out, im.id);
    for (double v : {im.q_cam_world.w(), im.q_cam_world.x(), im.q_cam_world.y(), im.q_cam_world.z()}) Put(out, v);
    for (int k = 0; k < 3; ++k) Put<double>(out, im.t_cam_world[k]);
    Put<uint32_t>(out, im.camera_id);
    out += im.name;
    out += '\0';
    Put<uint64_t>(out, im.points2d.size());
    for (const auto& p : im.points2d) {
      Put<double>(out, p.x);
      Put<double>(out, p.y);
      Put<uint64_t>(out, p.point3d_id);
    }
  }
  return out;
}

std::string ColmapPointsBinary(const std::vector<ColmapPoint3D>& points) {
  std::string out;
  Put<uint64_t>(out, points.size());
  for (const auto& p : points) {
    Put<uint64_t>(out, p.id);
    for (int k = 0; k < 3; ++k) Put<double>(out, p.xyz[k]);
    for (uint8_t c : p.rgb) Put<uint8_t>(out, c);
    Put<double>(out, p.error);
    Put<uint64_t>(out, p.track.size());
    for (const auto& e : p.track) {
      Put<uint32_t>(out, e.image_id);
      Put<uint32_t>(out, e.point2d_idx);
    }
  }
  return out;
}

}  // namespace rs
