#include "formats/geo/cameras_csv.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <string_view>

#include "formats/input_error.h"

namespace rs {
namespace {

constexpr std::string_view kHeader =
    "frame,t_ns,easting_m,northing_m,height_m,lat_deg,lon_deg,h_ellipsoid_m,roll_deg,pitch_deg,yaw_deg,status";
constexpr size_t kColumns = 12;

struct Cell {
  std::string_view text;
  int64_t column = 1;
};

std::vector<Cell> SplitRow(std::string_view line) {
  std::vector<Cell> cells;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    const size_t end = comma == std::string_view::npos ? line.size() : comma;
    cells.push_back({line.substr(start, end - start), static_cast<int64_t>(start) + 1});
    if (comma == std::string_view::npos) return cells;
    start = comma + 1;
  }
}

template <typename T>
T Parse(const Cell& c, const std::string& path, int64_t line, const char* what) {
  T v{};
  const auto [end, ec] = std::from_chars(c.text.data(), c.text.data() + c.text.size(), v);
  if (ec != std::errc() || end != c.text.data() + c.text.size() || c.text.empty())
    throw InputError(InputLocation::Line(path, line, c.column), fmt::format("{}: '{}' is not a number", what, c.text));
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(v))
      throw InputError(InputLocation::Line(path, line, c.column), fmt::format("{}: non-finite value", what));
  }
  return v;
}

}  // namespace

std::vector<CameraRow> ReadCamerasCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  const std::string p = path.string();
  if (!in) throw InputError(InputLocation::File(p), "cannot open cameras.csv");
  std::string line;
  if (!std::getline(in, line) || std::string_view(line).substr(0, kHeader.size()) != kHeader)
    throw InputError(InputLocation::Line(p, 1), fmt::format("expected header '{}'", kHeader));
  std::vector<CameraRow> rows;
  for (int64_t n = 2; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const auto c = SplitRow(line);
    if (c.size() != kColumns)
      throw InputError(InputLocation::Line(p, n), fmt::format("{} fields, expected {}", c.size(), kColumns));
    CameraRow r;
    r.frame = Parse<int64_t>(c[0], p, n, "frame");
    r.t_ns = Parse<int64_t>(c[1], p, n, "t_ns");
    r.status = std::string(c[11].text);
    if (!c[2].text.empty()) {
      r.crs = Eigen::Vector3d(Parse<double>(c[2], p, n, "easting_m"), Parse<double>(c[3], p, n, "northing_m"),
                              Parse<double>(c[4], p, n, "height_m"));
      r.lat_deg = Parse<double>(c[5], p, n, "lat_deg");
      r.lon_deg = Parse<double>(c[6], p, n, "lon_deg");
      r.h_ellipsoid_m = Parse<double>(c[7], p, n, "h_ellipsoid_m");
    }
    if (!c[8].text.empty())
      r.rpy_deg = Eigen::Vector3d(Parse<double>(c[8], p, n, "roll_deg"), Parse<double>(c[9], p, n, "pitch_deg"),
                                  Parse<double>(c[10], p, n, "yaw_deg"));
    rows.push_back(std::move(r));
  }
  return rows;
}

}  // namespace rs
