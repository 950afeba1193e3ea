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
enum class Role {
  kNone,
  kTimeAbs,
  kTimeRel,
  kLat,
  kLon,
  kAlt,
  kSpeed,
  kSats,
  kHAcc,
  kVAcc,
  kYaw,
  kPitch,
  kRoll,
  kPhoto
};

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
  if (In(n, {"longitude", "lon", "lng", "long", "lon_deg", "gps_lon", "gps_lng", "gps_longitude"}))
    return col->role = Role::kLon, true;
  if (In(n, {"datetime", "date_time", "timestamp", "time_utc", "utc", "utc_time", "gps_time", "date", "time", "t",
             "time_s", "time_ms", "t_s", "t_ns", "timestamp_ms", "timestamp_s"})) {
    // AirData: "datetime(utc)" is absolute, "time(millisecond)" is since the flight started.
    if (In(n, {"time", "t", "time_s", "time_ms", "t_s"}) &&
        (u == "millisecond" || u == "ms" || u == "s" || n == "time_s" || n == "time_ms" || n == "t_s") &&
        n != "timestamp") {
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
  struct AltName {
    const char* name;
    AltitudeReference ref;
    int rank;
  };
  static const AltName kAlts[] = {
      {"altitude_above_sealevel", AltitudeReference::kAmsl, 4},
      {"alt_msl", AltitudeReference::kAmsl, 4},
      {"altitude_msl", AltitudeReference::kAmsl, 4},
      {"altitude_amsl", AltitudeReference::kAmsl, 4},
      {"amsl", AltitudeReference::kAmsl, 4},
      {"msl", AltitudeReference::kAmsl, 4},
      {"elevation", AltitudeReference::kAmsl, 4},
      {"ele", AltitudeReference::kAmsl, 4},
      {"alt_ellipsoid", AltitudeReference::kEllipsoid, 3},
      {"ellipsoid_height", AltitudeReference::kEllipsoid, 3},
      {"height_ellipsoid", AltitudeReference::kEllipsoid, 3},
      {"hae", AltitudeReference::kEllipsoid, 3},
      {"altitude_wgs84", AltitudeReference::kEllipsoid, 3},
      {"alt", AltitudeReference::kUnknown, 2},
      {"altitude", AltitudeReference::kUnknown, 2},
      {"alt_m", AltitudeReference::kUnknown, 2},
      {"height_above_takeoff", AltitudeReference::kTakeoff, 1},
      {"rel_alt", AltitudeReference::kTakeoff, 1},
      {"relative_altitude", AltitudeReference::kTakeoff, 1},
      {"height", AltitudeReference::kTakeoff, 1},
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
  if (In(n, {"satellites", "sats", "num_sats", "nsat", "numsat", "satellite_count"}))
    return col->role = Role::kSats, true;
  if (In(n, {"h_acc", "hacc", "h_acc_m", "horizontal_accuracy"})) {
    if (!LengthScale(u, &col->scale)) return *why = "unknown length unit '" + u + "'", false;
    return col->role = Role::kHAcc, true;
  }
  if (In(n, {"v_acc", "vacc", "v_acc_m", "vertical_accuracy"})) {
    if (!LengthScale(u, &col->scale)) return *why = "unknown length unit '" + u + "'", false;
    return col->role = Role::kVAcc, true;
  }
  Role angle = Role::kNone;
  if (In(n, {"compass_heading", "yaw", "heading"}))
    angle = Role::kYaw;
  else if (n == "pitch")
    angle = Role::kPitch;
  else if (n == "roll")
    angle = Role::kRoll;
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

/// The input's lines with their 1-based numbers, so every error names the input line.
class CsvLines {
 public:
  CsvLines(std::istream& in, const std::string& path) : in_(in), path_(path) {}

  /// Reads the next line (a UTF-8 BOM dropped from line 1); false at the end.
  /// A line over 1 MiB is an error: a binary file must not be buffered whole.
  bool Next() {
    bool too_long = false;
    const bool ok = flightlog::GetLineBounded(in_, &line_, kMaxLineBytes, &too_long);
    if (too_long) throw InputError(InputLocation::Line(path_, line_no_ + 1), "line longer than 1 MiB");
    if (ok) ++line_no_;
    if (ok && line_no_ == 1 && line_.rfind("\xEF\xBB\xBF", 0) == 0) line_.erase(0, 3);  // UTF-8 BOM
    return ok;
  }
  /// Throws InputError at the current line (column `col`, -1 for none).
  [[noreturn]] void Fail(int64_t col, const std::string& msg) const {
    throw InputError(InputLocation::Line(path_, line_no_, col), msg);
  }
  const std::string& line() const { return line_; }
  int64_t line_no() const { return line_no_; }
  const std::string& path() const { return path_; }
  bool bad() const { return in_.bad(); }

 private:
  std::istream& in_;
  const std::string& path_;
  std::string line_;
  int64_t line_no_ = 0;
};

/// The header's fields, its delimiter and its line number.
struct HeaderLine {
  std::vector<flightlog::CsvField> fields;
  char delim = ',';
  int64_t line_no = 0;
};

/// The header is the first line that is not blank or a '#' comment; it uses ';'
/// when it has ';' and no ',' (European spreadsheet exports).
HeaderLine ReadHeaderLine(CsvLines& lines) {
  HeaderLine h;
  int64_t bad_col = 0;
  while (lines.Next()) {
    const std::string_view t = Trim(lines.line());
    if (t.empty() || t.front() == '#') continue;
    if (t.find(',') == std::string_view::npos && t.find(';') != std::string_view::npos) h.delim = ';';
    if (!flightlog::SplitCsvLine(lines.line(), &h.fields, &bad_col, h.delim))
      lines.Fail(bad_col, "unterminated quote in header");
    h.line_no = lines.line_no();
    return h;
  }
  throw InputError(InputLocation::Line(lines.path(), 1), "empty file: no CSV header");
}

/// Every header column with a role, and the names of those without one (listed in a note).
struct Columns {
  std::vector<Column> used;
  std::vector<std::string> ignored;
  bool airdata = false;  // AirData's own column names were seen

  /// The column for role `r`: the first one, or for altitude the preferred one.
  const Column* Find(Role r) const {
    const Column* best = nullptr;
    for (const Column& c : used) {
      if (c.role != r) continue;
      if (!best || (r == Role::kAlt && c.alt_rank > best->alt_rank)) best = &c;
    }
    return best;
  }
};

/// Classifies each header cell; a known column with an unconvertible unit is an
/// error at its column (guessing the unit would be silent).
Columns ClassifyColumns(const HeaderLine& header, const CsvLines& lines) {
  Columns out;
  for (size_t i = 0; i < header.fields.size(); ++i) {
    const ColumnName cn = SplitName(header.fields[i].text);
    Column c;
    c.index = static_cast<int>(i);
    c.header = std::string(Trim(header.fields[i].text));
    std::string why;
    if (!Classify(cn, &c, &why)) lines.Fail(header.fields[i].column, "column '" + c.header + "': " + why);
    if (cn.name == "datetime" && cn.unit == "utc") out.airdata = true;
    if (cn.name == "time" && cn.unit == "millisecond") out.airdata = true;
    if (c.role == Role::kNone) {
      if (!c.header.empty()) out.ignored.push_back(c.header);
      continue;
    }
    out.used.push_back(c);
  }
  return out;
}

/// The one column chosen per role (pointers into Columns::used); null where absent.
struct Roles {
  const Column *lat, *lon, *t_abs, *t_rel, *alt, *speed, *sats, *hacc, *vacc, *yaw, *pitch, *roll, *photo;
  bool attitude;  // yaw, pitch and roll all present
};

/// Picks one column per role and lists the other columns of a taken role as
/// ignored; a header without latitude or longitude is an error at its line.
Roles PickRoles(Columns* columns, const std::string& path, int64_t header_line) {
  Roles r;
  r.lat = columns->Find(Role::kLat);
  r.lon = columns->Find(Role::kLon);
  if (!r.lat || !r.lon)
    throw InputError(InputLocation::Line(path, header_line),
                     std::string("header has no ") + (!r.lat ? "latitude" : "longitude") +
                         " column (looked for lat/latitude, lon/lng/longitude)");
  r.t_abs = columns->Find(Role::kTimeAbs);
  r.t_rel = columns->Find(Role::kTimeRel);
  r.alt = columns->Find(Role::kAlt);
  r.speed = columns->Find(Role::kSpeed);
  r.sats = columns->Find(Role::kSats);
  r.hacc = columns->Find(Role::kHAcc);
  r.vacc = columns->Find(Role::kVAcc);
  r.yaw = columns->Find(Role::kYaw);
  r.pitch = columns->Find(Role::kPitch);
  r.roll = columns->Find(Role::kRoll);
  r.photo = columns->Find(Role::kPhoto);
  r.attitude = r.yaw && r.pitch && r.roll;
  for (const Column& c : columns->used)
    if ((c.role == Role::kAlt && &c != r.alt) || (c.role != Role::kAlt && &c != columns->Find(c.role)))
      columns->ignored.push_back(c.header + " (duplicate role)");
  return r;
}

/// How the absolute time column reads, decided from its first non-empty value.
struct AbsTimeFormat {
  double scale = 0;  // s per unit; 0: ISO text, or epoch with unit decided from the first value
  bool is_text = false, decided = false;
  int64_t n_no_zone = 0;  // ISO date-times without a zone, taken as UTC
};

/// One row's fields, bound to the line they came from so errors point at a cell.
struct RowFields {
  const CsvLines& lines;
  const std::vector<flightlog::CsvField>& fields;

  std::string_view Text(const Column* c) const { return Trim(fields[c->index].text); }
  [[noreturn]] void Fail(const Column* c, const std::string& msg) const { lines.Fail(fields[c->index].column, msg); }
  /// The cell as a number in SI units, nullopt when empty; outside [lo, hi] is an error.
  std::optional<double> Number(const Column* c, double lo, double hi) const {
    const std::string_view s = Text(c);
    if (s.empty()) return std::nullopt;
    double v;
    if (!flightlog::ParseDouble(s, &v)) Fail(c, "column '" + c->header + "': not a number: '" + std::string(s) + "'");
    v *= c->scale;
    if (v < lo || v > hi)
      Fail(c, "column '" + c->header + "': " + flightlog::FormatDouble(v) + " outside [" + flightlog::FormatDouble(lo) +
                  ", " + flightlog::FormatDouble(hi) + "]");
    return v;
  }
};

/// The absolute time cell as UTC ns: ISO-8601 text or an epoch number whose unit
/// is named or, failing that, read from the first value's magnitude.
int64_t ParseAbsTime(const RowFields& row, const Column* t_abs, AbsTimeFormat* format) {
  std::string s(row.Text(t_abs));
  if (!format->decided) {
    double v;
    format->is_text = !flightlog::ParseDouble(s, &v);
    if (!format->is_text && format->scale == 0) format->scale = EpochScaleFromMagnitude(v);
    if (!format->is_text && format->scale == 0)
      row.Fail(t_abs,
               "column '" + t_abs->header + "': number " + s +
                   " is not an epoch time in s, ms, us or ns (name the unit, e.g. time(s), for a relative clock)");
    format->decided = true;
  }
  if (format->is_text) {
    if (s.size() >= 10 && s[4] == '/' && s[7] == '/') s[4] = s[7] = '-';  // "2019/05/03 14:22:11"
    int64_t ns;
    bool has_zone;
    if (!flightlog::ParseIso8601(s, &ns, &has_zone))
      row.Fail(t_abs, "column '" + t_abs->header + "': not an ISO-8601 date-time: '" + s + "'");
    format->n_no_zone += !has_zone;
    return ns;
  }
  double v;
  if (!flightlog::ParseDouble(s, &v)) row.Fail(t_abs, "column '" + t_abs->header + "': not a number: '" + s + "'");
  const double sec = v * format->scale;
  // 2001-01-01 .. 2200-01-01 (also keeps the nanosecond value inside int64).
  if (!(sec >= 978307200.0 && sec < 7258118400.0))
    row.Fail(t_abs, "column '" + t_abs->header + "': epoch time " + s + " is not between 2001 and 2200");
  return static_cast<int64_t>(std::llround(sec * 1e6)) * 1000;  // microsecond precision of a double epoch
}

/// One data row's values, range-checked; a position of exactly 0,0 counts as none.
Row ParseRow(const RowFields& row, const Roles& c, AbsTimeFormat* abs_format) {
  Row r;
  r.line = row.lines.line_no();
  if (c.t_abs && !row.Text(c.t_abs).empty()) r.t_abs_ns = ParseAbsTime(row, c.t_abs, abs_format);
  if (c.t_rel) {
    if (const auto v = row.Number(c.t_rel, -1e9, 1e9)) r.t_rel_s = *v;
  }
  const auto la = row.Number(c.lat, -90, 90);
  const auto lo = row.Number(c.lon, -180, 180);
  if (la.has_value() != lo.has_value())
    row.Fail(la ? c.lon : c.lat, "latitude and longitude must be both set or both empty");
  r.has_pos = la.has_value() && !(*la == 0 && *lo == 0);
  if (r.has_pos) {
    r.fix.lat_deg = *la;
    r.fix.lon_deg = *lo;
  }
  if (c.alt) {
    if (const auto v = row.Number(c.alt, -1e5, 1e6)) r.fix.alt_m = *v, r.fix.alt_ref = c.alt->alt_ref;
  }
  if (c.speed) {
    if (const auto v = row.Number(c.speed, 0, 1e4)) r.fix.ground_speed_m_s = *v;
  }
  if (c.sats) {
    if (const auto v = row.Number(c.sats, 0, 1000)) {
      if (*v != std::floor(*v)) row.Fail(c.sats, "column '" + c.sats->header + "': satellite count is not an integer");
      r.fix.satellites = static_cast<int>(*v);
    }
  }
  if (c.hacc) {
    if (const auto v = row.Number(c.hacc, 0, 1e7)) r.fix.h_acc_m = *v;
  }
  if (c.vacc) {
    if (const auto v = row.Number(c.vacc, 0, 1e7)) r.fix.v_acc_m = *v;
  }
  if (c.attitude) {
    const auto y = row.Number(c.yaw, -360, 360), p = row.Number(c.pitch, -90, 90), ro = row.Number(c.roll, -180, 180);
    if (y && p && ro) r.has_att = true, r.yaw = *y, r.pitch = *p, r.roll = *ro;
  }
  if (c.photo) {
    const auto v = row.Number(c.photo, 0, 1);
    r.photo = v && *v != 0;
  }
  return r;
}

/// Reads every data row after the header; each must have the header's field
/// count (a trailing delimiter is tolerated). Counts the rows without a position.
std::vector<Row> ReadRows(CsvLines& lines, const HeaderLine& header, const Roles& roles, AbsTimeFormat* abs_format,
                          int64_t* dropped_no_pos) {
  const size_t header_n = header.fields.size();
  std::vector<flightlog::CsvField> fields;
  int64_t bad_col = 0;
  std::vector<Row> rows;
  while (lines.Next()) {
    const std::string_view t = Trim(lines.line());
    if (t.empty() || t.front() == '#') continue;
    if (!flightlog::SplitCsvLine(lines.line(), &fields, &bad_col, header.delim))
      lines.Fail(bad_col, "unterminated quote");
    if (fields.size() == header_n + 1 && Trim(fields.back().text).empty()) fields.pop_back();  // trailing delimiter
    if (fields.size() != header_n)
      lines.Fail(-1, "expected " + std::to_string(header_n) + " fields (as in the header), got " +
                         std::to_string(fields.size()));
    const Row r = ParseRow(RowFields{lines, fields}, roles, abs_format);
    if (!r.has_pos) ++*dropped_no_pos;
    rows.push_back(r);
  }
  if (lines.bad()) throw InputError(InputLocation::File(lines.path()), "read error");
  return rows;
}

/// AirData: datetime(utc) has 1 s resolution (truncated), time(millisecond) is fine-grained.
/// Each row bounds the UTC of the relative clock's zero: dt <= utc0 + rel < dt + 1 s.
std::vector<int64_t> AnchorRelativeClock(const std::vector<Row>& rows, const Roles& c, FlightTrack* track) {
  std::vector<int64_t> t_ns(rows.size(), 0);
  int64_t lo = INT64_MIN, hi = INT64_MAX;
  for (const Row& r : rows) {
    const int64_t rel_ns = static_cast<int64_t>(std::llround(*r.t_rel_s * 1e9));
    lo = std::max(lo, *r.t_abs_ns - rel_ns);
    hi = std::min(hi, *r.t_abs_ns + 1000000000 - rel_ns);
  }
  if (lo >= hi) {
    track->notes.push_back("'" + c.t_rel->header + "' and '" + c.t_abs->header +
                           "' disagree by more than their 1 s resolution; t_ns from '" + c.t_abs->header +
                           "' alone (1 s steps)");
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = *rows[i].t_abs_ns;
  } else {
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = lo + static_cast<int64_t>(std::llround(*rows[i].t_rel_s * 1e9));
    track->notes.push_back("t_ns = UTC from '" + c.t_abs->header + "' (1 s resolution) anchored to '" +
                           c.t_rel->header + "': anchor uncertainty " + flightlog::FormatDouble((hi - lo) * 1e-9) +
                           " s");
  }
  return t_ns;
}

/// Each row's t_ns and the track's time base, from the best clock every row has:
/// absolute (refined by a relative clock), absolute, relative, or the row index.
/// An empty time cell where the column is the clock used is an error at its row.
std::vector<int64_t> RowTimes(const std::vector<Row>& rows, const Roles& c, const AbsTimeFormat& abs_format,
                              const std::string& path, FlightTrack* track) {
  std::vector<int64_t> t_ns(rows.size(), 0);
  const bool all_abs =
      c.t_abs && std::all_of(rows.begin(), rows.end(), [](const Row& r) { return r.t_abs_ns.has_value(); });
  const bool all_rel =
      c.t_rel && std::all_of(rows.begin(), rows.end(), [](const Row& r) { return r.t_rel_s.has_value(); });
  if (c.t_abs && !all_abs)
    for (const Row& r : rows)
      if (!r.t_abs_ns)
        throw InputError(InputLocation::Line(path, r.line, static_cast<int64_t>(c.t_abs->index) + 1),
                         "empty time in column '" + c.t_abs->header + "'");
  if (c.t_rel && !all_rel && !all_abs)
    for (const Row& r : rows)
      if (!r.t_rel_s)
        throw InputError(InputLocation::Line(path, r.line), "empty time in column '" + c.t_rel->header + "'");
  const bool whole_seconds =
      all_abs && std::all_of(rows.begin(), rows.end(), [](const Row& r) { return *r.t_abs_ns % 1000000000 == 0; });
  if (rows.empty()) {
    // nothing to time
  } else if (all_abs && all_rel && whole_seconds) {
    t_ns = AnchorRelativeClock(rows, c, track);
    track->time_base = TimeBase::kUtc;
  } else if (all_abs) {
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = *rows[i].t_abs_ns;
    track->time_base = TimeBase::kUtc;
    track->notes.push_back("t_ns = UTC from column '" + c.t_abs->header + "'" +
                           (abs_format.is_text ? std::string(" (ISO-8601)")
                                               : " (epoch, unit " + flightlog::FormatDouble(abs_format.scale) + " s)"));
    if (abs_format.n_no_zone > 0)
      track->notes.push_back(std::to_string(abs_format.n_no_zone) + " date-times without a zone, taken as UTC");
  } else if (all_rel) {
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = static_cast<int64_t>(std::llround(*rows[i].t_rel_s * 1e9));
    track->time_base = TimeBase::kBoot;
    track->notes.push_back("t_ns from relative time column '" + c.t_rel->header + "' (origin unknown, no UTC)");
  } else {
    for (size_t i = 0; i < rows.size(); ++i) t_ns[i] = static_cast<int64_t>(i);
    track->time_base = TimeBase::kBoot;
    track->notes.push_back("no time column: the track has NO time; t_ns is the data row's index (0, 1, 2, ...)");
  }
  return t_ns;
}

/// Fixes, attitude and camera events from the timed rows; a photo flag stays 1
/// for a few rows, so only its rising edge is a shot.
void AddSamples(std::vector<Row>& rows, const std::vector<int64_t>& t_ns, FlightTrack* track) {
  bool prev_photo = false;
  int64_t photo_seq = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    Row& r = rows[i];
    if (r.has_pos) {
      r.fix.t_ns = t_ns[i];
      r.fix.source_pos = r.line;
      track->fixes.push_back(r.fix);
    }
    if (r.has_att) {
      track->attitude.push_back(flightlog::AttitudeFromEulerDeg(t_ns[i], r.roll, r.pitch, r.yaw));
      track->attitude.back().source_pos = r.line;
    }
    if (r.photo && !prev_photo) {
      CameraEvent e;
      e.t_ns = t_ns[i];
      e.sequence = photo_seq++;
      e.source_pos = r.line;
      if (r.has_pos)
        e.lat_deg = r.fix.lat_deg, e.lon_deg = r.fix.lon_deg, e.alt_m = r.fix.alt_m, e.alt_ref = r.fix.alt_ref;
      track->camera_events.push_back(e);
    }
    prev_photo = r.photo;
  }
}

/// Notes on which columns were used and converted, what was dropped and what was ignored.
void AddColumnNotes(const Roles& c, const Columns& columns, int64_t dropped_no_pos, FlightTrack* track) {
  if (c.alt)
    track->notes.push_back("altitude from column '" + c.alt->header + "' (" + ToString(c.alt->alt_ref) +
                           (c.alt->scale != 1 ? ", feet converted to metres" : "") + ")");
  else
    track->notes.push_back("no altitude column");
  if (c.speed && c.speed->scale != 1) track->notes.push_back("speed from '" + c.speed->header + "' converted to m/s");
  if (c.attitude)
    track->notes.push_back("attitude from '" + c.yaw->header + "', '" + c.pitch->header + "', '" + c.roll->header +
                           "'");
  if (c.photo)
    track->notes.push_back(std::to_string(track->camera_events.size()) + " camera events from rising edges of '" +
                           c.photo->header + "'");
  if (dropped_no_pos > 0)
    track->notes.push_back(std::to_string(dropped_no_pos) + " rows without a position (empty or 0,0) dropped");
  const std::vector<std::string>& ignored = columns.ignored;
  if (!ignored.empty()) {
    std::string list;
    for (size_t i = 0; i < ignored.size() && i < 12; ++i) list += (i ? ", " : "") + ignored[i];
    if (ignored.size() > 12) list += ", ... (" + std::to_string(ignored.size()) + " in all)";
    track->notes.push_back("columns not used: " + list);
  }
}

}  // namespace

FlightTrack ReadFlightCsv(std::istream& in, const std::string& path) {
  FlightTrack track;
  track.source_path = path;
  track.format = "csv";

  CsvLines lines(in, path);
  const HeaderLine header = ReadHeaderLine(lines);
  Columns columns = ClassifyColumns(header, lines);
  if (columns.airdata) track.format = "airdata-csv";
  const Roles roles = PickRoles(&columns, path, header.line_no);

  AbsTimeFormat abs_format;
  abs_format.scale = roles.t_abs ? roles.t_abs->scale : 0;
  int64_t dropped_no_pos = 0;
  std::vector<Row> rows = ReadRows(lines, header, roles, &abs_format, &dropped_no_pos);

  const std::vector<int64_t> t_ns = RowTimes(rows, roles, abs_format, path, &track);
  AddSamples(rows, t_ns, &track);
  AddColumnNotes(roles, columns, dropped_no_pos, &track);
  if (track.fixes.empty()) throw InputError(InputLocation::Line(path, header.line_no), "no row has a position");
  flightlog::SortTrackByTime(&track);
  return track;
}

FlightTrack ReadFlightCsv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadFlightCsv(in, path.string());
}

}  // namespace rs
