#include "formats/flight_log/kitti_oxts.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <istream>

#include "formats/flight_log/attitude_math.h"
#include "formats/flight_log/flight_log_text.h"
#include "formats/flight_log/time_parse.h"
#include "formats/flight_log/track_sort.h"
#include "formats/input_error.h"

namespace rs {
namespace {

constexpr size_t kMaxLineBytes = 1 << 16;
constexpr int kNumFields = 30;
enum Field { kLat, kLon, kAlt, kRoll, kPitch, kYaw, kVn, kVe, kPosAccuracy = 23, kNumSats = 26, kPosMode = 27 };

/// OXTS RT GPS position mode -> GnssFix::fix_type (OXTS RT manual's mode table).
int FixTypeFromPosMode(int mode) {
  switch (mode) {
    case 0:
    case 1:
    case 10:
    case 11: return 0;  // none, search, no data, blanked
    case 3:
    case 13: return 3;  // SPS (standalone)
    case 4:
    case 7:
    case 8:
    case 14:
    case 18: return 4;  // differential, WAAS, OmniSTAR VBS, ...
    case 5:
    case 9:
    case 15:
    case 17: return 5;  // RTK float, OmniSTAR HP/XP
    case 6:
    case 16: return 6;   // RTK integer
    default: return -1;  // Doppler-only and unknown modes
  }
}

}  // namespace

std::vector<int64_t> ReadKittiTimestamps(std::istream& in, const std::string& path) {
  std::vector<int64_t> out;
  std::string line;
  bool too_long = false;
  int64_t line_no = 0;
  while (flightlog::GetLineBounded(in, &line, kMaxLineBytes, &too_long)) {
    ++line_no;
    const std::string_view t = flightlog::Trim(line);
    if (t.empty()) continue;
    int64_t ns;
    bool has_zone;
    if (!flightlog::ParseIso8601(t, &ns, &has_zone))
      throw InputError(InputLocation::Line(path, line_no, 1),
                       "not a date-time 'YYYY-MM-DD HH:MM:SS.fffffffff': '" + std::string(t.substr(0, 60)) + "'");
    out.push_back(ns);
  }
  if (too_long) throw InputError(InputLocation::Line(path, line_no + 1), "line longer than 64 KiB");
  if (in.bad()) throw InputError(InputLocation::File(path), "read error");
  if (out.empty()) throw InputError(InputLocation::File(path), "no timestamps");
  return out;
}

void ReadKittiOxtsRecord(std::istream& in, const std::string& path, int64_t t_ns, FlightTrack* track) {
  std::string line;
  bool too_long = false;
  int64_t line_no = 0;
  std::array<double, kNumFields> v{};
  int n = 0;
  int64_t first_line = -1;
  while (flightlog::GetLineBounded(in, &line, kMaxLineBytes, &too_long)) {
    ++line_no;
    size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i >= line.size()) break;
      const size_t b = i;
      while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
      const std::string_view tok = std::string_view(line).substr(b, i - b);
      if (n >= kNumFields)
        throw InputError(InputLocation::Line(path, line_no, static_cast<int64_t>(b) + 1), "more than 30 values");
      if (!flightlog::ParseDouble(tok, &v[n]))
        throw InputError(
            InputLocation::Line(path, line_no, static_cast<int64_t>(b) + 1),
            "value " + std::to_string(n + 1) + " is not a number: '" + std::string(tok.substr(0, 40)) + "'");
      if (first_line < 0) first_line = line_no;
      ++n;
    }
  }
  if (too_long) throw InputError(InputLocation::Line(path, line_no + 1), "line longer than 64 KiB");
  if (in.bad()) throw InputError(InputLocation::File(path), "read error");
  if (n != kNumFields)
    throw InputError(InputLocation::Line(path, std::max<int64_t>(line_no, 1)),
                     "expected 30 values, got " + std::to_string(n));
  const InputLocation where = InputLocation::Line(path, first_line);
  if (std::abs(v[kLat]) > 90 || std::abs(v[kLon]) > 180) throw InputError(where, "lat/lon out of range");
  if (std::abs(v[kAlt]) > 1e5) throw InputError(where, "implausible altitude " + flightlog::FormatDouble(v[kAlt]));
  if (std::abs(v[kRoll]) > 4 || std::abs(v[kPitch]) > 2 || std::abs(v[kYaw]) > 4)
    throw InputError(where, "roll/pitch/yaw outside +-pi (radians expected)");
  if (v[kNumSats] < 0 || v[kNumSats] > 1000 || v[kNumSats] != std::floor(v[kNumSats]))
    throw InputError(where, "numsats is not a satellite count");
  if (v[kPosAccuracy] < 0) throw InputError(where, "negative pos_accuracy");

  GnssFix f;
  f.t_ns = t_ns;
  f.lat_deg = v[kLat];
  f.lon_deg = v[kLon];
  f.alt_m = v[kAlt];
  f.alt_ref = AltitudeReference::kAmsl;  // KITTI devkit: "altitude of the oxts-unit", above sea level
  f.satellites = static_cast<int>(v[kNumSats]);
  f.fix_type = v[kPosMode] == std::floor(v[kPosMode]) ? FixTypeFromPosMode(static_cast<int>(v[kPosMode])) : -1;
  f.h_acc_m = v[kPosAccuracy];
  f.ground_speed_m_s = std::hypot(v[kVn], v[kVe]);
  track->fixes.push_back(f);
  // KITTI: body x forward, y left, z up; yaw 0 = east, counter-clockwise; pitch positive = front down;
  // roll positive = left side up. Aerospace (FRD->NED): yaw from north clockwise, pitch nose up, roll right down.
  constexpr double r2d = 180.0 / M_PI;
  track->attitude.push_back(
      flightlog::AttitudeFromEulerDeg(t_ns, v[kRoll] * r2d, -v[kPitch] * r2d, 90.0 - v[kYaw] * r2d));
}

FlightTrack ReadKittiOxts(const std::filesystem::path& oxts_dir) {
  namespace fs = std::filesystem;
  const fs::path ts_path = oxts_dir / "timestamps.txt";
  const fs::path data_dir = oxts_dir / "data";
  std::ifstream ts_in(ts_path, std::ios::binary);
  if (!ts_in) throw InputError(InputLocation::File(ts_path.string()), "cannot open KITTI OXTS timestamps");
  const std::vector<int64_t> stamps = ReadKittiTimestamps(ts_in, ts_path.string());

  std::error_code ec;
  if (!fs::is_directory(data_dir, ec))
    throw InputError(InputLocation::File(data_dir.string()), "missing KITTI OXTS data folder");
  std::vector<std::pair<int64_t, fs::path>> files;
  for (const fs::directory_entry& e : fs::directory_iterator(data_dir, ec)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".txt") continue;
    int64_t index;
    const std::string stem = e.path().stem().string();
    if (stem.size() != 10 || !flightlog::ParseInt64(stem, &index) || index < 0)
      throw InputError(InputLocation::File(e.path().string()), "OXTS record file name is not a 10-digit frame index");
    if (index >= static_cast<int64_t>(stamps.size()))
      throw InputError(InputLocation::File(e.path().string()), "frame index " + std::to_string(index) +
                                                                   " has no line in " + ts_path.string() + " (" +
                                                                   std::to_string(stamps.size()) + " lines)");
    files.emplace_back(index, e.path());
  }
  if (ec) throw InputError(InputLocation::File(data_dir.string()), "cannot list folder: " + ec.message());
  if (files.empty()) throw InputError(InputLocation::File(data_dir.string()), "no OXTS record files (NNNNNNNNNN.txt)");
  std::sort(files.begin(), files.end());

  FlightTrack track;
  track.source_path = oxts_dir.string();
  track.format = "kitti-oxts";
  track.time_base = TimeBase::kUtc;
  for (const auto& [index, p] : files) {
    std::ifstream in(p, std::ios::binary);
    if (!in) throw InputError(InputLocation::File(p.string()), "cannot open file");
    ReadKittiOxtsRecord(in, p.string(), stamps[static_cast<size_t>(index)], &track);
  }
  track.notes.push_back(std::to_string(files.size()) + " OXTS records of " + std::to_string(stamps.size()) +
                        " timestamps");
  track.notes.push_back(
      "timestamps.txt taken as UTC (KITTI does not name the zone); alt is above sea level (KITTI devkit)");
  flightlog::SortTrackByTime(&track);
  return track;
}

}  // namespace rs
