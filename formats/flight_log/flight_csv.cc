#include "formats/flight_log/flight_csv.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <istream>
#include <optional>

#include "formats/flight_log/attitude_math.h"
#include "formats/flight_log/flight_log_text.h"
#include "formats/flight_log/time_parse.h"
#include "formats/flight_log/track_sort.h"
#include "formats/input_error.h"

namespace rs {
namespace {

using flightlog::Trim;

constexpr size_t kMaxLineBytes = 1 << 20;
constexpr double kFeetToM = 0.3048;

/// A header cell split into a normalized name and its unit: " Speed(MPH)" -> {"speed", "mph"}.
struct ColumnName {
  std::string name, unit;
};

ColumnName SplitName(std::string_view raw) {
  std::string s = flightlog::ToLowerAscii(Trim(raw));
  ColumnName c;
  for (auto [open, close] : {std::pair{'(', ')'}, std::pair{'[', ']'}}) {
    const size_t b = s.find(open);
    if (b != std::string::npos && !s.empty() && s.back() == close) {
      c.unit = std::string(Trim(std::string_view(s).substr(b + 1, s.size() - b - 2)));
      s = std::string(Trim(std::string_view(s).substr(0, b)));
      break;
    }
  }
  for (char& ch : s)
    if (ch == ' ' || ch == '-' || ch == '.') ch = '_';
  c.name = s;
  return c;
}

bool In(const std::string& s, std::initializer_list<const char*> names) {
  return std::any_of(names.begin(), names.end(), [&](const char* n) { return s == n; });
}

/// Column roles the reader understands.
enum class Role { kNone, kTimeAbs, kTimeRel, kLat, kLon, kAlt, kSpeed, kSats, kHAcc, kVAcc, kYaw, kPitch, kRoll, kPhoto };

struct Column {
  Role role = Role::kNone;
  int index = -1;
  double scale = 1;  // value * scale = SI (m, m/s, s for relative time, rad->deg for angles)
  AltitudeReference alt_ref = AltitudeReference::kUnknown;
  int alt_rank = 0;  // higher is preferred
  std::string header;
};

// Scale to metres for a length unit; false when the unit is not a length.
bool LengthScale(const std::string& unit, double* scale) {
  if (unit.empty() || In(unit, {"m", "meter", "meters", "metre", "metres"})) return *scale = 1, true;
  if (In(unit, {"ft", "feet", "foot"})) return *scale = kFeetToM, true;
  return false;
}

bool SpeedScale(const std::string& unit, double* scale) {
  if (unit.empty() || In(unit, {"m/s", "mps", "meters/second", "ms"})) return *scale = 1, true;
  if (In(unit, {"mph"})) return *scale = 0.44704, true;
  if (In(unit, {"km/h", "kph", "kmh"})) return *scale = 1 / 3.6, true;
  if (In(unit, {"kn", "kt", "kts", "knots"})) return *scale = 1852.0 / 3600.0, true;
  return false;
}

bool AngleScale(const std::string& unit, double* scale) {
  if (unit.empty() || In(unit, {"deg", "degree", "degrees"})) return *scale = 1, true;
  if (In(unit, {"rad", "radian", "radians"})) return *scale = 180.0 / M_PI, true;
  return false;
}

// Seconds per unit of a relative/epoch time column; 0 when the unit is unknown/absent.
double TimeUnitSeconds(const std::string& unit) {
  if (In(unit, {"s", "sec", "second", "seconds"})) return 1;
  if (In(unit, {"ms", "millisecond", "milliseconds", "msec"})) return 1e-3;
  if (In(unit, {"us", "microsecond", "microseconds", "usec"})) return 1e-6;
  if (In(unit, {"ns", "nanosecond", "nanoseconds"})) return 1e-9;
  return 0;
}

/// Decides the role of one header cell. Returns false with *why when a known
/// column has a unit we cannot convert (an error: guessing would be silent).
bool Classify(const ColumnName& c, Column* col, std::string* why) {
  const std::string& n = c.name;
  const std::string& u = c.unit;
  if (In(n, {"latitude", "lat", "lat_deg", "gps_lat", "gps_latitude"})) return col->role = Role::kLat, true;
  if (In(n, {"longitude", "lon", "lng", "long", "lon_deg", "gps_lon", "gps_lng", "gps_longitude"})) return col->role = Role::kLon, true;
  if (In(n, {"datetime", "date_time", "timestamp", "time_utc", "utc", "utc_time", "gps_time", "date", "time", "t", "time_s", "time_ms", "t_s", "t_ns", "timestamp_ms", "timestamp_s"})) {
    // AirData: "datetime(utc)" is absolute, "time(millisecond)" is since the flight started.
    if (In(n, {"time", "t", "time_s", "time_ms", "t_s"}) && (u == "millisecond" || u == "ms" || u == "s" || n == "time_s" || n == "time_ms" || n == "t_s") && n != "timestamp") {
      double sec = TimeUnitSeconds(u);
      if (sec == 0) sec = n == "time_ms" ? 1e-3 : 1;
      col->role = Role::kTimeRel;
      col->scale = sec;
      return true;
    }
    col->role = Role::kTimeAbs;
    col->scale = n == "t_ns" ? 1e-9 : n == "timestamp_ms" ? 1e-3 : TimeUnitSeconds(u);  // 0: decide from the values
    return true;
  }
  struct AltName { const char* name; AltitudeReference ref; int rank; };
  static const AltName kAlts[] = {
      {"altitude_above_sealevel", AltitudeReference::kAmsl, 4}, {"alt_msl", AltitudeReference::kAmsl, 4},
      {"altitude_msl", AltitudeReference::kAmsl, 4}, {"altitude_amsl", AltitudeReference::kAmsl, 4},
      {"amsl", AltitudeReference::kAmsl, 4}, {"msl", AltitudeReference::kAmsl, 4},
      {"elevation", AltitudeReference::kAmsl, 4}, {"ele", AltitudeReference::kAmsl, 4},
      {"alt_ellipsoid", AltitudeReference::kEllipsoid, 3}, {"ellipsoid_height", AltitudeReference::kEllipsoid, 3},
      {"height_ellipsoid", AltitudeReference::kEllipsoid, 3}, {"hae", AltitudeReference::kEllipsoid, 3},
      {"altitude_wgs84", AltitudeReference::kEllipsoid, 3},
      {"alt", AltitudeReference::kUnknown, 2}, {"altitude", AltitudeReference::kUnknown, 2}, {"alt_m", AltitudeReference::kUnknown, 2},
      {"height_above_takeoff", AltitudeReference::kTakeoff, 1}, {"rel_alt", AltitudeReference::kTakeoff, 1},
      {"relative_altitude", AltitudeReference::kTakeoff, 1}, {"height", AltitudeReference::kTakeoff, 1},
  };
  for (const AltName& a : kAlts) {
    if (n != a.name) continue;
    if (!LengthScale(u, &col->scale)) return *why = "unknown length unit '" + u + "'", false;
    col->role = Role::kAlt;
    col->alt_ref = a.ref;
    col->alt_rank = a.rank;
    return true;
  }
  if (In(n, {"speed", "ground_speed", "groundspeed", "gs", "speed_m_s", "h_speed", "hspeed"})) {
    if (!SpeedScale(u, &col->scale)) return *why = "unknown speed unit '" + u + "'", false;
    return col->role = Role::kSpeed, true;
  }
  if (In(n, {"satellites", "sats", "num_sats", "nsat", "numsat", "satellite_count"})) return col->role = Role::kSats, true;
  if (In(n, {"h_acc", "hacc", "h_acc_m", "horizontal_accuracy"})) {
    if (!LengthScale(u, &col->scale)) return *why = "unknown length unit '" + u + "'", false;
    return col->role = Role::kHAcc, true;
  }
  if (In(n, {"v_acc", "vacc", "v_acc_m", "vertical_accuracy"})) {
    if (!LengthScale(u, &col->scale)) return *why = "unknown length unit '" + u + "'", false;
    return col->role = Role::kVAcc, true;
  }
  Role angle = Role::kNone;
  if (In(n, {"compass_heading", "yaw", "heading"})) angle = Role::kYaw;
  else if (n == "pitch") angle = Role::kPitch;
  else if (n == "roll") angle = Role::kRoll;
  if (angle != Role::kNone) {
    if (!AngleScale(u, &col->scale)) return *why = "unknown angle unit '" + u + "'", false;
    return col->role = angle, true;
  }
  if (In(n, {"isphoto", "is_photo", "photo"})) return col->role = Role::kPhoto, true;
  return true;  // not ours
}

/// Epoch time from a number whose unit is not named: the magnitude decides
/// (plausible dates 2001..2286 in s, ms, us or ns). 0 when it fits none.
double EpochScaleFromMagnitude(double v) {
  const double a = std::abs(v);
  if (a >= 1e9 && a < 1e10) return 1;
  if (a >= 1e12 && a < 1e13) return 1e-3;
  if (a >= 1e15 && a < 1e16) return 1e-6;
  if (a >= 1e18 && a < 1e19) return 1e-9;
  return 0;
}

struct Row {
  int64_t line;
  std::optional<int64_t> t_abs_ns;  // UTC
  std::optional<double> t_rel_s;
  GnssFix fix;
  bool has_pos = false;
  bool has_att = false;
  double yaw = 0, pitch = 0, roll = 0;
  bool photo = false;
};

}  // namespace

FlightTrack ReadFlightCsv(std::istream& in, const std::string& path) {
  FlightTrack track;
  track.source_path = path;
  track.format = "csv";

  std::string line;
  int64_t line_no = 0;
  bool too_long = false;
  auto next_line = [&]() {
    const bool ok = flightlog::GetLineBounded(in, &line, kMaxLineBytes, &too_long);
    if (too_long) throw InputError(InputLocation::Line(path, line_no + 1), "line longer than 1 MiB");
    if (ok) ++line_no;
    if (ok && line_no == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 BOM
    return ok;
  };
  auto fail = [&](int64_t col, const std::string& msg) { throw InputError(InputLocation::Line(path, line_no, col), msg); };

  // Header: the first line that is not blank or a '#' comment.
  std::vector<flightlog::CsvField> fields;
  int64_t bad_col = 0;
  char delim = ',';
  bool have_header = false;
  while (!have_header && next_line()) {
    const std::string_view t = Trim(line);
    if (t.empty() || t.front() == '#') continue;
    if (t.find(',') == std::string_view::npos && t.find(';') != std::string_view::npos) delim = ';';
    if (!flightlog::SplitCsvLine(line, &fields, &bad_col, delim)) fail(bad_col, "unterminated quote in header");
    have_header = true;
  }
  if (!have_header) throw InputError(InputLocation::Line(path, 1), "empty file: no CSV header");
  const int64_t header_line = line_no;
  const size_t header_n = fields.size();

  std::vector<Column> cols;
  std::vector<std::string> ignored;
  bool airdata = false;
  for (size_t i = 0; i < fields.size(); ++i) {
    const ColumnName cn = SplitName(fields[i].text);
    Column c;
    c.index = static_cast<int>(i);
    c.header = std::string(Trim(fields[i].text));
    std::string why;
    if (!Classify(cn, &c, &why)) fail(fields[i].column, "column '" + c.header + "': " + why);
    if (cn.name == "datetime" && cn.unit == "utc") airdata = true;
    if (cn.name == "time" && cn.unit == "millisecond") airdata = true;
    if (c.role == Role::kNone) {
      if (!c.header.empty()) ignored.push_back(c.header);
      continue;
    }
    cols.push_back(c);
  }
  if (airdata) track.format = "airdata-csv";
  // One column per role; for altitude keep the preferred one.
  auto find = [&](Role r) -> const Column* {
    const Column* best = nullptr;
    for (const Column& c : cols) {
      if (c.role != r) continue;
      if (!best || (r == Role::kAlt && c.alt_rank > best->alt_rank)) best = &c;
    }
    return best;
  };
  const Column* lat = find(Role::kLat);
  const Column* lon = find(Role::kLon);
  if (!lat || !lon) throw InputError(InputLocation::Line(path, header_line), std::string("header has no ") + (!lat ? "latitude" : "longitude") + " column (looked for lat/latitude, lon/lng/longitude)");
  const Column* t_abs = find(Role::kTimeAbs);
  const Column* t_rel = find(Role::kTimeRel);
  const Column* alt = find(Role::kAlt);
  const Column* speed = find(Role::kSpeed);
  const Column* sats = find(Role::kSats);
  const Column* hacc = find(Role::kHAcc);
  const Column* vacc = find(Role::kVAcc);
  const Column* yaw = find(Role::kYaw);
  const Column* pitch = find(Role::kPitch);
  const Column* roll = find(Role::kRoll);
  const Column* photo = find(Role::kPhoto);
  const bool attitude = yaw && pitch && roll;
  for (const Column& c : cols)
    if ((c.role == Role::kAlt && &c != alt) || (c.role != Role::kAlt && &c != find(c.role))) ignored.push_back(c.header + " (duplicate role)");

  // Rows.
  std::vector<Row> rows;
  int64_t dropped_no_pos = 0;
  double abs_scale = t_abs ? t_abs->scale : 0;  // 0: ISO text, or epoch with unit decided from the first value
  bool abs_is_text = false, abs_decided = false;
  int64_t n_no_zone = 0;
  while (next_line()) {
    const std::string_view t = Trim(line);
    if (t.empty() || t.front() == '#') continue;
    if (!flightlog::SplitCsvLine(line, &fields, &bad_col, delim)) fail(bad_col, "unterminated quote");
    if (fields.size() == header_n + 1 && Trim(fields.back().text).empty()) fields.pop_back();  // trailing delimiter
    if (fields.size() != header_n) fail(-1, "expected " + std::to_string(header_n) + " fields (as in the header), got " + std::to_string(fields.size()));
    auto text = [&](const Column* c) { return Trim(fields[c->index].text); };
    auto number = [&](const Column* c, double lo, double hi) -> std::optional<double> {
      const std::string_view s = text(c);
      if (s.empty()) return std::nullopt;
      double v;
      if (!flightlog::ParseDouble(s, &v)) fail(fields[c->index].column, "column '" + c->header + "': not a number: '" + std::string(s) + "'");
      v *= c->scale;
      if (v < lo || v > hi) fail(fields[c->index].column, "column '" + c->header + "': " + flightlog::FormatDouble(v) + " outside [" + flightlog::FormatDouble(lo) + ", " + flightlog::FormatDouble(hi) + "]");
      return v;
    };
    Row r;
    r.line = line_no;
    if (t_abs && !text(t_abs).empty()) {
      std::string s(text(t_abs));
      if (!abs_decided) {
        double v;
        abs_is_text = !flightlog::ParseDouble(s, &v);
        if (!abs_is_text && abs_scale == 0) abs_scale = EpochScaleFromMagnitude(v);
        if (!abs_is_text && abs_scale == 0)
          fail(fields[t_abs->index].column, "column '" + t_abs->header + "': number " + s + " is not an epoch time in s, ms, us or ns (name the unit, e.g. time(s), for a relative clock)");
        abs_decided = true;
      }
      if (abs_is_text) {
        if (s.size() >= 10 && s[4] == '/' && s[7] == '/') s[4] = s[7] = '-';  // "2019/05/03 14:22:11"
        int64_t ns;
        bool has_zone;
        if (!flightlog::ParseIso8601(s, &ns, &has_zone)) fail(fields[t_abs->index].column, "column '" + t_abs->header + "': not an ISO-8601 date-time: '" + s + "'");
        n_no_zone += !has_zone;
        r.t_abs_ns = ns;
      } else {
        double v;
        if (!flightlog::ParseDouble(s, &v)) fail(fields[t_abs->index].column, "column '" + t_abs->header + "': not a number: '" + s + "'");
        const double sec = v * abs_scale;
        // 2001-01-01 .. 2200-01-01 (also keeps the nanosecond value inside int64).
        if (!(sec >= 978307200.0 && sec < 7258118400.0)) fail(fields[t_abs->index].column, "column '" + t_abs->header + "': epoch time " + s + " is not between 2001 and 2200");
        r.t_abs_ns = static_cast<int64_t>(std::llround(sec * 1e6)) * 1000;  // microsecond precision of a double epoch
      }
    }
    if (t_rel) {
      if (const auto v = number(t_rel, -1e9, 1e9)) r.t_rel_s = *v;
    }
    const auto la = number(lat, -90, 90);
    const auto lo = number(lon, -180, 180);
    if (la.has_value() != lo.has_value()) fail(fields[(la ? lon : lat)->index].column, "latitude and longitude must be both set or both empty");
    r.has_pos = la.has_value() && !(*la == 0 && *lo == 0);
    if (r.has_pos) {
      r.fix.lat_deg = *la;
      r.fix.lon_deg = *lo;
    }
    if (alt) {
      if (const auto v = number(alt, -1e5, 1e6)) r.fix.alt_m = *v, r.fix.alt_ref = alt->alt_ref;
    }
    if (speed) {
      if (const auto v = number(speed, 0, 1e4)) r.fix.ground_speed_m_s = *v;
    }
    if (sats) {
      if (const auto v = number(sats, 0, 1000)) {
        if (*v != std::floor(*v)) fail(fields[sats->index].column, "column '" + sats->header + "': satellite count is not an integer");
        r.fix.satellites = static_cast<int>(*v);
      }
    }
    if (hacc) {
      if (const auto v = number(hacc, 0, 1e7)) r.fix.h_acc_m = *v;
    }
    if (vacc) {
      if (const auto v = number(vacc, 0, 1e7)) r.fix.v_acc_m = *v;
    }
    if (attitude) {
      const auto y = number(yaw, -360, 360), p = number(pitch, -90, 90), ro = number(roll, -180, 180);
      if (y && p && ro) r.has_att = true, r.yaw = *y, r.pitch = *p, r.roll = *ro;
    }
    if (photo) {
      const auto v = number(photo, 0, 1);
      r.photo = v && *v != 0;
    }
    if (!r.has_pos) ++dropped_no_pos;
    rows.push_back(r);
  }
  if (in.bad()) throw InputError(InputLocation::File(path), "read error");

  // Time for each row.
  std::vector<int64_t> t_ns(rows.size(), 0);
  const bool all_abs = t_abs && std::all_of(rows.begin(), rows.end(), [](const Row& r) { return r.t_abs_ns.has_value(); });
  const bool all_rel = t_rel && std::all_of(rows.begin(), rows.end(), [](const Row& r) { return r.t_rel_s.has_value(); });
  if (t_abs && !all_abs)
    for (const Row& r : rows)
      if (!r.t_abs_ns) throw InputError(InputLocation::Line(path, r.line, static_cast<int64_t>(t_abs->index) + 1), "empty time in column '" + t_abs->header + "'");
  if (t_rel && !all_rel && !all_abs)
    for (const Row& r : rows)
      if (!r.t_rel_s) throw InputError(InputLocation::Line(path, r.line), "empty time in column '" + t_rel->header + "'");
  const bool whole_seconds = all_abs && std::all_of(rows.begin(), rows.end(), [](const Row& r) { return *r.t_abs_ns % 1000000000 == 0; });
  if (rows.empty()) {
    // nothing to time
  } else if (all_abs && all_rel && whole_seconds) {
    // AirData: datetime(utc) has 1 s resolution (truncated), time(millisecond) is fine-grained.
    // Each row bounds the UTC of the relative clock's zero: dt <= utc0 + rel < dt + 1 s.
    int64_t lo = INT64_MIN, hi = INT64_MAX;
    for (const Row& r : rows) {
      const int64_t rel_ns = static_cast<int64_t>(std::llround(*r.t_rel_s * 1e9));
      lo = std::max(lo, *r.t_abs_ns - rel_ns);
      hi = std::min(hi, *r.t_abs_ns + 1000000000 - rel_ns);
    }
    if (lo >= hi) {
      track.notes.push_back("'" + t_rel->header + "' and '" + t_abs->header + "' disagree by more than their 1 s resolution; t_ns from '" + t_abs->header + "' alone (1 s steps)");
      for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = *rows[i].t_abs_ns;
    } else {
      for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = lo + static_cast<int64_t>(std::llround(*rows[i].t_rel_s * 1e9));
      track.notes.push_back("t_ns = UTC from '" + t_abs->header + "' (1 s resolution) anchored to '" + t_rel->header + "': anchor uncertainty " +
                            flightlog::FormatDouble((hi - lo) * 1e-9) + " s");
    }
    track.time_base = TimeBase::kUtc;
  } else if (all_abs) {
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = *rows[i].t_abs_ns;
    track.time_base = TimeBase::kUtc;
    track.notes.push_back("t_ns = UTC from column '" + t_abs->header + "'" + (abs_is_text ? std::string(" (ISO-8601)") : " (epoch, unit " + flightlog::FormatDouble(abs_scale) + " s)"));
    if (n_no_zone > 0) track.notes.push_back(std::to_string(n_no_zone) + " date-times without a zone, taken as UTC");
  } else if (all_rel) {
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = static_cast<int64_t>(std::llround(*rows[i].t_rel_s * 1e9));
    track.time_base = TimeBase::kBoot;
    track.notes.push_back("t_ns from relative time column '" + t_rel->header + "' (origin unknown, no UTC)");
  } else {
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = static_cast<int64_t>(i);
    track.time_base = TimeBase::kBoot;
    track.notes.push_back("no time column: the track has NO time; t_ns is the data row's index (0, 1, 2, ...)");
  }

  bool prev_photo = false;
  int64_t photo_seq = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    Row& r = rows[i];
    if (r.has_pos) {
      r.fix.t_ns = t_ns[i];
      track.fixes.push_back(r.fix);
    }
    if (r.has_att) track.attitude.push_back(flightlog::AttitudeFromEulerDeg(t_ns[i], r.roll, r.pitch, r.yaw));
    if (r.photo && !prev_photo) {  // a photo flag stays 1 for a few rows: the rising edge is the shot
      CameraEvent e;
      e.t_ns = t_ns[i];
      e.sequence = photo_seq++;
      if (r.has_pos) e.lat_deg = r.fix.lat_deg, e.lon_deg = r.fix.lon_deg, e.alt_m = r.fix.alt_m, e.alt_ref = r.fix.alt_ref;
      track.camera_events.push_back(e);
    }
    prev_photo = r.photo;
  }
  if (alt) track.notes.push_back("altitude from column '" + alt->header + "' (" + ToString(alt->alt_ref) + (alt->scale != 1 ? ", feet converted to metres" : "") + ")");
  else track.notes.push_back("no altitude column");
  if (speed && speed->scale != 1) track.notes.push_back("speed from '" + speed->header + "' converted to m/s");
  if (attitude) track.notes.push_back("attitude from '" + yaw->header + "', '" + pitch->header + "', '" + roll->header + "'");
  if (photo) track.notes.push_back(std::to_string(track.camera_events.size()) + " camera events from rising edges of '" + photo->header + "'");
  if (dropped_no_pos > 0) track.notes.push_back(std::to_string(dropped_no_pos) + " rows without a position (empty or 0,0) dropped");
  if (!ignored.empty()) {
    std::string list;
    for (size_t i = 0; i < ignored.size() && i < 12; ++i) list += (i ? ", " : "") + ignored[i];
    if (ignored.size() > 12) list += ", ... (" + std::to_string(ignored.size()) + " in all)";
    track.notes.push_back("columns not used: " + list);
  }
  if (track.fixes.empty()) throw InputError(InputLocation::Line(path, header_line), "no row has a position");
  flightlog::SortTrackByTime(&track);
  return track;
}

FlightTrack ReadFlightCsv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadFlightCsv(in, path.string());
}

}  // namespace rs
