#include "formats/flight_log/track_csv.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <ostream>

#include "formats/flight_log/flight_log_text.h"
#include "formats/flight_log/track_sort.h"
#include "formats/input_error.h"

namespace rs {
namespace {

using flightlog::CsvField;

constexpr size_t kMaxLineBytes = 1 << 20;
constexpr const char* kMagic = "# roadsurvey flight track v1";

enum Col {
  kTNs,
  kType,
  kLat,
  kLon,
  kAlt,
  kAltRef,
  kFixType,
  kSatellites,
  kHAcc,
  kVAcc,
  kQw,
  kQx,
  kQy,
  kQz,
  kSequence,
  kGroundSpeed,
  kNumCols
};
constexpr std::array<const char*, kNumCols> kColNames = {
    "t_ns",    "type",    "lat_deg", "lon_deg", "alt_m", "alt_ref", "fix_type", "satellites",
    "h_acc_m", "v_acc_m", "qw",      "qx",      "qy",    "qz",      "sequence", "ground_speed_m_s"};
constexpr int kNumRequiredCols = kSequence + 1;  // ground_speed_m_s is optional

std::string Num(double v) { return std::isfinite(v) ? flightlog::FormatDouble(v) : std::string(); }
std::string Int(int64_t v, int64_t unknown) { return v == unknown ? std::string() : std::to_string(v); }

bool ParseAltRef(std::string_view s, AltitudeReference* r) {
  for (auto c : {AltitudeReference::kEllipsoid, AltitudeReference::kAmsl, AltitudeReference::kTakeoff,
                 AltitudeReference::kUnknown}) {
    if (s == ToString(c)) {
      *r = c;
      return true;
    }
  }
  return false;
}

/// One data row with the header's column mapping; every accessor throws with the cell's location.
class Row {
 public:
  Row(const std::string& path, int64_t line, const std::vector<CsvField>& fields, const std::array<int, kNumCols>& map)
      : path_(path), line_(line), fields_(fields), map_(map) {}

  bool Has(Col c) const { return map_[c] >= 0 && !flightlog::Trim(fields_[map_[c]].text).empty(); }
  std::string_view Text(Col c) const { return flightlog::Trim(fields_[map_[c]].text); }
  [[noreturn]] void Fail(Col c, const std::string& msg) const {
    const int64_t col = map_[c] >= 0 ? fields_[map_[c]].column : -1;
    throw InputError(InputLocation::Line(path_, line_, col), std::string(kColNames[c]) + ": " + msg);
  }
  void Require(Col c, const char* type) const {
    if (!Has(c)) Fail(c, std::string("required for ") + type + " rows but empty");
  }
  void RequireEmpty(Col c, const char* type) const {
    if (Has(c)) Fail(c, std::string("must be empty for ") + type + " rows, got '" + std::string(Text(c)) + "'");
  }
  double Double(Col c, double lo, double hi) const {
    double v;
    if (!flightlog::ParseDouble(Text(c), &v)) Fail(c, "not a number: '" + std::string(Text(c)) + "'");
    if (v < lo || v > hi) Fail(c, Num(v) + " outside [" + Num(lo) + ", " + Num(hi) + "]");
    return v;
  }
  double OptDouble(Col c, double lo, double hi) const { return Has(c) ? Double(c, lo, hi) : kNaN; }
  int64_t Int64(Col c, int64_t lo, int64_t hi) const {
    int64_t v;
    if (!flightlog::ParseInt64(Text(c), &v)) Fail(c, "not an integer: '" + std::string(Text(c)) + "'");
    if (v < lo || v > hi)
      Fail(c, std::to_string(v) + " outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  }
  AltitudeReference AltRef(bool alt_present) const {
    if (!Has(kAltRef)) {
      if (alt_present) Fail(kAltRef, "required when alt_m is set (ellipsoid, amsl, takeoff or unknown)");
      return AltitudeReference::kUnknown;
    }
    AltitudeReference r;
    if (!ParseAltRef(Text(kAltRef), &r))
      Fail(kAltRef, "'" + std::string(Text(kAltRef)) + "' is not one of ellipsoid, amsl, takeoff, unknown");
    return r;
  }

 private:
  const std::string& path_;
  int64_t line_;
  const std::vector<CsvField>& fields_;
  const std::array<int, kNumCols>& map_;
};

}  // namespace

void WriteTrackCsv(std::ostream& out, const FlightTrack& track) {
  const bool with_speed = std::any_of(track.fixes.begin(), track.fixes.end(),
                                      [](const GnssFix& f) { return std::isfinite(f.ground_speed_m_s); });
  out << kMagic << ", time_base=" << ToString(track.time_base) << '\n';
  for (const std::string& note : track.notes) {
    std::string one_line = note;
    std::replace(one_line.begin(), one_line.end(), '\n', ' ');
    std::replace(one_line.begin(), one_line.end(), '\r', ' ');
    out << "# note: " << one_line << '\n';
  }
  for (int c = 0; c < kNumRequiredCols; ++c) out << (c ? "," : "") << kColNames[c];
  if (with_speed) out << ',' << kColNames[kGroundSpeed];
  out << '\n';

  // Merge the three (sorted) streams by time so the file reads chronologically.
  size_t ig = 0, ia = 0, ic = 0;
  const auto& g = track.fixes;
  const auto& a = track.attitude;
  const auto& cam = track.camera_events;
  while (ig < g.size() || ia < a.size() || ic < cam.size()) {
    const int64_t tg = ig < g.size() ? g[ig].t_ns : INT64_MAX;
    const int64_t ta = ia < a.size() ? a[ia].t_ns : INT64_MAX;
    const int64_t tc = ic < cam.size() ? cam[ic].t_ns : INT64_MAX;
    std::array<std::string, kNumCols> cell;
    if (ig < g.size() && tg <= ta && tg <= tc) {
      const GnssFix& f = g[ig++];
      cell[kTNs] = std::to_string(f.t_ns);
      cell[kType] = "gnss";
      cell[kLat] = Num(f.lat_deg);
      cell[kLon] = Num(f.lon_deg);
      cell[kAlt] = Num(f.alt_m);
      cell[kAltRef] = ToString(f.alt_ref);
      cell[kFixType] = Int(f.fix_type, -1);
      cell[kSatellites] = Int(f.satellites, -1);
      cell[kHAcc] = Num(f.h_acc_m);
      cell[kVAcc] = Num(f.v_acc_m);
      cell[kGroundSpeed] = Num(f.ground_speed_m_s);
    } else if (ia < a.size() && ta <= tc) {
      const AttitudeSample& s = a[ia++];
      cell[kTNs] = std::to_string(s.t_ns);
      cell[kType] = "attitude";
      cell[kQw] = Num(s.qw);
      cell[kQx] = Num(s.qx);
      cell[kQy] = Num(s.qy);
      cell[kQz] = Num(s.qz);
    } else {
      const CameraEvent& e = cam[ic++];
      cell[kTNs] = std::to_string(e.t_ns);
      cell[kType] = "camera";
      cell[kLat] = Num(e.lat_deg);
      cell[kLon] = Num(e.lon_deg);
      cell[kAlt] = Num(e.alt_m);
      cell[kAltRef] = ToString(e.alt_ref);
      cell[kSequence] = Int(e.sequence, -1);
    }
    const int ncols = with_speed ? kNumCols : kNumRequiredCols;
    for (int c = 0; c < ncols; ++c) out << (c ? "," : "") << cell[c];
    out << '\n';
  }
}

FlightTrack ReadTrackCsv(std::istream& in, const std::string& path) {
  FlightTrack track;
  track.source_path = path;
  track.format = "roadsurvey-csv";

  std::string line;
  int64_t line_no = 0;
  bool too_long = false;
  auto next_line = [&]() {
    const bool ok = flightlog::GetLineBounded(in, &line, kMaxLineBytes, &too_long);
    if (too_long) throw InputError(InputLocation::Line(path, line_no + 1), "line longer than 1 MiB");
    if (ok) ++line_no;
    return ok;
  };

  // Line 1: magic + time base.
  if (!next_line())
    throw InputError(InputLocation::Line(path, 1),
                     "empty file, expected '" + std::string(kMagic) + ", time_base=utc|boot'");
  {
    const std::string_view first = flightlog::Trim(line);
    const std::string prefix = std::string(kMagic) + ", time_base=";
    if (first.substr(0, prefix.size()) != prefix) {
      if (first.rfind("# roadsurvey flight track v", 0) == 0)
        throw InputError(InputLocation::Line(path, 1, 1),
                         "unsupported track CSV version (this reader knows v1): '" + std::string(first) + "'");
      throw InputError(InputLocation::Line(path, 1, 1),
                       "not a roadsurvey track CSV: first line must be '" + prefix + "utc|boot'");
    }
    const std::string_view tb = flightlog::Trim(first.substr(prefix.size()));
    if (tb == "utc")
      track.time_base = TimeBase::kUtc;
    else if (tb == "boot")
      track.time_base = TimeBase::kBoot;
    else
      throw InputError(InputLocation::Line(path, 1, static_cast<int64_t>(prefix.size()) + 1),
                       "time_base must be utc or boot, got '" + std::string(tb) + "'");
  }

  // Notes, then the header.
  std::vector<CsvField> fields;
  int64_t bad_col = 0;
  std::array<int, kNumCols> map;
  map.fill(-1);
  bool have_header = false;
  while (!have_header && next_line()) {
    const std::string_view t = flightlog::Trim(line);
    if (t.empty()) continue;
    if (t.front() == '#') {
      constexpr std::string_view kNote = "# note: ";
      if (t.substr(0, kNote.size()) == kNote) track.notes.emplace_back(t.substr(kNote.size()));
      continue;
    }
    if (!flightlog::SplitCsvLine(line, &fields, &bad_col))
      throw InputError(InputLocation::Line(path, line_no, bad_col), "unterminated quote in header");
    for (size_t i = 0; i < fields.size(); ++i) {
      const std::string_view name = flightlog::Trim(fields[i].text);
      const auto it = std::find_if(kColNames.begin(), kColNames.end(), [&](const char* n) { return name == n; });
      if (it == kColNames.end())
        throw InputError(InputLocation::Line(path, line_no, fields[i].column),
                         "unknown column '" + std::string(name) + "'");
      const int c = static_cast<int>(it - kColNames.begin());
      if (map[c] >= 0)
        throw InputError(InputLocation::Line(path, line_no, fields[i].column),
                         "duplicate column '" + std::string(name) + "'");
      map[c] = static_cast<int>(i);
    }
    for (int c = 0; c < kNumRequiredCols; ++c)
      if (map[c] < 0)
        throw InputError(InputLocation::Line(path, line_no),
                         std::string("header lacks required column '") + kColNames[c] + "'");
    have_header = true;
  }
  if (!have_header) throw InputError(InputLocation::Line(path, line_no + 1), "missing header line (t_ns,type,...)");

  while (next_line()) {
    const std::string_view t = flightlog::Trim(line);
    if (t.empty() || t.front() == '#') continue;
    if (!flightlog::SplitCsvLine(line, &fields, &bad_col))
      throw InputError(InputLocation::Line(path, line_no, bad_col), "unterminated quote");
    int nh = 0;
    for (int c : map) nh += c >= 0;
    if (static_cast<int>(fields.size()) != nh)
      throw InputError(InputLocation::Line(path, line_no),
                       "expected " + std::to_string(nh) + " fields, got " + std::to_string(fields.size()));
    const Row row(path, line_no, fields, map);
    row.Require(kTNs, "all");
    const int64_t t_ns = row.Int64(kTNs, INT64_MIN, INT64_MAX);
    const std::string_view type = row.Text(kType);
    if (type == "gnss") {
      for (Col c : {kQw, kQx, kQy, kQz, kSequence}) row.RequireEmpty(c, "gnss");
      row.Require(kLat, "gnss");
      row.Require(kLon, "gnss");
      GnssFix f;
      f.t_ns = t_ns;
      f.lat_deg = row.Double(kLat, -90, 90);
      f.lon_deg = row.Double(kLon, -180, 180);
      f.alt_m = row.OptDouble(kAlt, -1e5, 1e6);
      f.alt_ref = row.AltRef(row.Has(kAlt));
      f.fix_type = row.Has(kFixType) ? static_cast<int>(row.Int64(kFixType, 0, 6)) : -1;
      f.satellites = row.Has(kSatellites) ? static_cast<int>(row.Int64(kSatellites, 0, 1000)) : -1;
      f.h_acc_m = row.OptDouble(kHAcc, 0, 1e7);
      f.v_acc_m = row.OptDouble(kVAcc, 0, 1e7);
      f.ground_speed_m_s = row.OptDouble(kGroundSpeed, 0, 1e4);
      f.source_pos = line_no;
      track.fixes.push_back(f);
    } else if (type == "attitude") {
      for (Col c : {kLat, kLon, kAlt, kAltRef, kFixType, kSatellites, kHAcc, kVAcc, kSequence, kGroundSpeed})
        row.RequireEmpty(c, "attitude");
      for (Col c : {kQw, kQx, kQy, kQz}) row.Require(c, "attitude");
      AttitudeSample s;
      s.t_ns = t_ns;
      s.qw = row.Double(kQw, -1.001, 1.001);
      s.qx = row.Double(kQx, -1.001, 1.001);
      s.qy = row.Double(kQy, -1.001, 1.001);
      s.qz = row.Double(kQz, -1.001, 1.001);
      const double norm = std::sqrt(s.qw * s.qw + s.qx * s.qx + s.qy * s.qy + s.qz * s.qz);
      if (std::abs(norm - 1) > 1e-3) row.Fail(kQw, "quaternion norm " + Num(norm) + " is not 1 (tolerance 1e-3)");
      if (std::abs(norm - 1) > 1e-12) {  // written with few digits: restore a unit quaternion
        s.qw /= norm, s.qx /= norm, s.qy /= norm, s.qz /= norm;
      }
      s.source_pos = line_no;
      track.attitude.push_back(s);
    } else if (type == "camera") {
      for (Col c : {kFixType, kSatellites, kHAcc, kVAcc, kQw, kQx, kQy, kQz, kGroundSpeed})
        row.RequireEmpty(c, "camera");
      if (row.Has(kLat) != row.Has(kLon))
        row.Fail(row.Has(kLat) ? kLon : kLat, "lat_deg and lon_deg must be both set or both empty");
      CameraEvent e;
      e.t_ns = t_ns;
      e.sequence = row.Has(kSequence) ? row.Int64(kSequence, 0, INT64_MAX) : -1;
      e.lat_deg = row.OptDouble(kLat, -90, 90);
      e.lon_deg = row.OptDouble(kLon, -180, 180);
      e.alt_m = row.OptDouble(kAlt, -1e5, 1e6);
      e.alt_ref = row.AltRef(row.Has(kAlt));
      e.source_pos = line_no;
      track.camera_events.push_back(e);
    } else {
      row.Fail(kType, "'" + std::string(type) + "' is not one of gnss, attitude, camera");
    }
  }
  if (in.bad()) throw InputError(InputLocation::File(path), "read error");
  flightlog::SortTrackByTime(&track);
  return track;
}

FlightTrack ReadTrackCsv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadTrackCsv(in, path.string());
}

}  // namespace rs
