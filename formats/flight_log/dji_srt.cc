#include "formats/flight_log/dji_srt.h"

#include <algorithm>
#include <cctype>
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

constexpr size_t kMaxLineBytes = 1 << 16;  // SRT lines are < 1 KiB; anything longer is not an SRT

/// A number with where it sits in the input.
struct Value {
  double v = kNaN;
  int64_t line = -1, column = -1;
  bool Has() const { return line >= 0; }
};

/// The GPS(a, b, c) call as written, before the (lon, lat) order is decided.
struct GpsCall {
  bool present = false;
  bool not_available = false;  // GPS(N/A,N/A,..): no fix
  double a = kNaN, b = kNaN;
  std::string third;  // "16" (integer: satellites) or "0.0M" (altitude with unit)
  int64_t line = -1, column = -1;
};

/// Everything one subtitle record says that the track needs.
struct Record {
  int64_t line = 0;  // line of the subtitle index
  int64_t index = 0;
  std::optional<int64_t> timecode_ns;
  std::optional<int64_t> datetime_ns;
  Value tag_lat, tag_lon, abs_alt, rel_alt, altitude, h, barometer, hb, hs, speed;
  GpsCall gps;
  GpsCall home;
  bool has_pry = false;
  double pitch_deg = 0, roll_deg = 0, yaw_deg = 0;
  bool HasPosition() const { return gps.present || tag_lat.Has() || tag_lon.Has(); }
};

class SrtParser {
 public:
  SrtParser(std::istream& in, const std::string& path) : in_(in), path_(path) {}
  std::vector<Record> Parse();

 private:
  [[noreturn]] void Fail(int64_t line, int64_t col, const std::string& msg) const {
    throw InputError(InputLocation::Line(path_, line, col), msg);
  }
  bool NextLine();
  void ParseTimecode(std::string_view s, Record* r);
  void ParsePayload(std::string s, Record* r);
  void ParseBracket(std::string_view inner, int64_t col0, Record* r);
  void ParseCall(std::string_view name, int64_t name_col, std::string_view args, int64_t col0, Record* r);
  void ParseItem(std::string_view item, int64_t col0, Record* r);
  Value Number(std::string_view text, int64_t col, const char* what, bool allow_units);

  std::istream& in_;
  const std::string& path_;
  std::string line_;
  int64_t line_no_ = 0;
};

bool SrtParser::NextLine() {
  bool too_long = false;
  const bool ok = flightlog::GetLineBounded(in_, &line_, kMaxLineBytes, &too_long);
  if (too_long) Fail(line_no_ + 1, -1, "line longer than 64 KiB: not an SRT text file");
  if (!ok) return false;
  ++line_no_;
  if (line_no_ == 1 && line_.rfind("\xEF\xBB\xBF", 0) == 0) line_.erase(0, 3);  // UTF-8 BOM
  return true;
}

bool IsIndexLine(std::string_view s) {
  s = Trim(s);
  if (s.empty() || s.size() > 12) return false;
  for (char c : s)
    if (c < '0' || c > '9') return false;
  return true;
}

// "HH:MM:SS,mmm" (also '.') -> ns; false when malformed.
bool ParseSrtTime(std::string_view s, int64_t* t_ns) {
  s = Trim(s);
  int64_t h = 0, m = 0, sec = 0, ms = 0;
  size_t i = 0;
  auto num = [&](int64_t* v, size_t min_digits, size_t max_digits) {
    const size_t b = i;
    *v = 0;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9' && i - b < max_digits) *v = *v * 10 + (s[i++] - '0');
    return i - b >= min_digits;
  };
  if (!num(&h, 1, 3) || i >= s.size() || s[i++] != ':') return false;
  if (!num(&m, 2, 2) || i >= s.size() || s[i++] != ':') return false;
  if (!num(&sec, 2, 2) || i >= s.size() || (s[i] != ',' && s[i] != '.')) return false;
  ++i;
  // Seconds = 60 occurs in Matrice 300 files ("00:00:59,000 --> 00:00:60,000"): it is unambiguous.
  if (!num(&ms, 3, 3) || i != s.size() || m > 59 || sec > 60) return false;
  *t_ns = ((h * 60 + m) * 60 + sec) * 1000000000LL + ms * 1000000LL;
  return true;
}

void SrtParser::ParseTimecode(std::string_view s, Record* r) {
  const size_t arrow = s.find("-->");
  int64_t start, end;
  if (!ParseSrtTime(s.substr(0, arrow), &start) || !ParseSrtTime(s.substr(arrow + 3), &end))
    Fail(line_no_, 1,
         "malformed subtitle timecode '" + std::string(Trim(s)) + "' (expected HH:MM:SS,mmm --> HH:MM:SS,mmm)");
  if (r->timecode_ns) Fail(line_no_, 1, "second timecode line in subtitle " + std::to_string(r->index));
  r->timecode_ns = start;
}

Value SrtParser::Number(std::string_view text, int64_t col, const char* what, bool allow_units) {
  std::string_view t = Trim(text);
  if (allow_units) {
    for (std::string_view unit : {"m/s", "m", "M", "\xC2\xB0" /* degree sign */}) {
      if (t.size() > unit.size() && t.substr(t.size() - unit.size()) == unit) {
        t.remove_suffix(unit.size());
        break;
      }
    }
  }
  Value v;
  if (!flightlog::ParseDouble(t, &v.v))
    Fail(line_no_, col, std::string(what) + ": not a number: '" + std::string(Trim(text)) + "'");
  v.line = line_no_;
  v.column = col;
  return v;
}

bool IsNotAvailable(std::string_view s) {
  s = Trim(s);
  return s == "N/A" || s == "n/a" || s == "NA";
}

void SrtParser::ParseBracket(std::string_view inner, int64_t col0, Record* r) {
  // "key : value" pairs, possibly several per bracket ("rel_alt: -2.400 abs_alt: 0.401").
  size_t i = 0;
  while (i < inner.size()) {
    while (i < inner.size() && inner[i] == ' ') ++i;
    const size_t kb = i;
    while (i < inner.size() && inner[i] != ':' && inner[i] != ' ') ++i;
    const std::string key = flightlog::ToLowerAscii(inner.substr(kb, i - kb));
    while (i < inner.size() && inner[i] == ' ') ++i;
    if (i >= inner.size() || inner[i] != ':') return;  // not a key:value bracket; camera text we do not use
    ++i;
    while (i < inner.size() && inner[i] == ' ') ++i;
    const size_t vb = i;
    while (i < inner.size() && inner[i] != ' ') ++i;
    const std::string_view val = inner.substr(vb, i - vb);
    const int64_t col = col0 + static_cast<int64_t>(vb);
    Value* dst = nullptr;
    if (key == "latitude")
      dst = &r->tag_lat;
    else if (key == "longitude" || key == "longtitude")
      dst = &r->tag_lon;  // DJI's typo in Mavic 2 firmware
    else if (key == "abs_alt")
      dst = &r->abs_alt;
    else if (key == "rel_alt")
      dst = &r->rel_alt;
    else if (key == "altitude")
      dst = &r->altitude;
    if (dst == nullptr) continue;
    if (dst->Has()) Fail(line_no_, col, "'" + key + "' given twice in one subtitle");
    *dst = Number(val, col, key.c_str(), false);
  }
}

void SrtParser::ParseCall(std::string_view name, int64_t name_col, std::string_view args, int64_t col0, Record* r) {
  std::vector<flightlog::CsvField> parts;
  int64_t bad = 0;
  flightlog::SplitCsvLine(args, &parts, &bad);
  auto col_of = [&](size_t k) { return col0 + parts[k].column - 1; };
  if (name == "GPS" || name == "HOME") {
    GpsCall& g = name == "GPS" ? r->gps : r->home;
    if (g.present) Fail(line_no_, name_col, std::string(name) + "(...) given twice in one subtitle");
    if (parts.size() < 2 || parts.size() > 3)
      Fail(line_no_, name_col, std::string(name) + "(...) needs 2 or 3 values, got " + std::to_string(parts.size()));
    g.present = true;
    g.line = line_no_;
    g.column = name_col;
    if (IsNotAvailable(parts[0].text) && IsNotAvailable(parts[1].text)) {
      g.not_available = true;
    } else {
      g.a = Number(parts[0].text, col_of(0), name == "GPS" ? "GPS first value" : "HOME first value", false).v;
      g.b = Number(parts[1].text, col_of(1), name == "GPS" ? "GPS second value" : "HOME second value", false).v;
    }
    if (parts.size() == 3) g.third = std::string(Trim(parts[2].text));
  } else if (name == "F.PRY") {
    if (parts.size() != 3) Fail(line_no_, name_col, "F.PRY(...) needs 3 values, got " + std::to_string(parts.size()));
    r->pitch_deg = Number(parts[0].text, col_of(0), "F.PRY pitch", true).v;
    r->roll_deg = Number(parts[1].text, col_of(1), "F.PRY roll", true).v;
    r->yaw_deg = Number(parts[2].text, col_of(2), "F.PRY yaw", true).v;
    if (std::abs(r->pitch_deg) > 90 || std::abs(r->roll_deg) > 180 || std::abs(r->yaw_deg) > 360)
      Fail(line_no_, name_col, "F.PRY angles out of range (pitch within +-90, roll +-180, yaw +-360 degrees)");
    r->has_pry = true;
  }
}

void SrtParser::ParseItem(std::string_view item, int64_t col0, Record* r) {
  // "KEY:VALUE", "KEY : VALUE" or "KEY VALUE".
  item = Trim(item);
  if (item.empty()) return;
  size_t sep = item.find(':');
  if (sep == std::string_view::npos) sep = item.find(' ');
  if (sep == std::string_view::npos) return;
  const std::string_view key = Trim(item.substr(0, sep));
  const std::string_view val = Trim(item.substr(sep + 1));
  Value* dst = nullptr;
  if (key == "BAROMETER")
    dst = &r->barometer;
  else if (key == "Hb")
    dst = &r->hb;
  else if (key == "Hs")
    dst = &r->hs;
  else if (key == "H")
    dst = &r->h;
  else if (key == "H.S")
    dst = &r->speed;
  if (dst == nullptr || IsNotAvailable(val)) return;
  const int64_t col = col0 + static_cast<int64_t>(val.data() - item.data());
  *dst = Number(val, col, std::string(key).c_str(), true);
}

void SrtParser::ParsePayload(std::string s, Record* r) {
  // 1. A date-time anywhere in the line (alone, or after HOME(...) in old firmware).
  for (size_t i = 0; i + 10 < s.size(); ++i) {
    if (!(s[i] >= '0' && s[i] <= '9') || (i > 0 && s[i - 1] >= '0' && s[i - 1] <= '9')) continue;
    size_t used = 0;
    int64_t t;
    if (flightlog::ParseDjiDateTime(std::string_view(s).substr(i), &used, &t)) {
      if (!r->datetime_ns) r->datetime_ns = t;
      // Trailing extra ",ddd" groups (seen in one firmware's first record) are noise.
      while (i + used < s.size() && (s[i + used] == ',' || (s[i + used] >= '0' && s[i + used] <= '9')) &&
             !(s[i + used] == ',' && i + used + 1 < s.size() && s[i + used + 1] == ' '))
        ++used;
      s.replace(i, used, used, ' ');
      i += used;
    }
  }
  // 2. HTML-ish tags and [key: value] brackets.
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '[' && s[i] != '<') continue;
    const char close = s[i] == '[' ? ']' : '>';
    const size_t e = s.find(close, i + 1);
    if (e == std::string::npos)
      Fail(line_no_, static_cast<int64_t>(i) + 1, std::string("unterminated '") + s[i] + "' (truncated record?)");
    if (s[i] == '[') ParseBracket(std::string_view(s).substr(i + 1, e - i - 1), static_cast<int64_t>(i) + 2, r);
    s.replace(i, e - i + 1, e - i + 1, ' ');
    i = e;
  }
  // 3. NAME(args) calls: GPS, HOME, F.PRY, G.PRY.
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '(') continue;
    size_t ne = i;
    while (ne > 0 && s[ne - 1] == ' ') --ne;
    size_t nb = ne;
    while (nb > 0 && (std::isalnum(static_cast<unsigned char>(s[nb - 1])) || s[nb - 1] == '.' || s[nb - 1] == '_'))
      --nb;
    const size_t e = s.find(')', i + 1);
    if (e == std::string::npos) Fail(line_no_, static_cast<int64_t>(i) + 1, "unterminated '(' (truncated record?)");
    ParseCall(std::string_view(s).substr(nb, ne - nb), static_cast<int64_t>(nb) + 1,
              std::string_view(s).substr(i + 1, e - i - 1), static_cast<int64_t>(i) + 2, r);
    s.replace(nb, e - nb + 1, e - nb + 1, ' ');
    i = e;
  }
  // 4. What is left: "KEY VALUE" items split by commas (DJI GO 4 style) or
  //    "KEY:VALUE" items split by blanks (older firmware).
  const bool commas = s.find(',') != std::string::npos;
  size_t b = 0;
  for (size_t i = 0; i <= s.size(); ++i) {
    const bool end = i == s.size() || (commas ? s[i] == ',' : s[i] == ' ');
    if (!end) continue;
    const std::string_view item = std::string_view(s).substr(b, i - b);
    const size_t lead = item.find_first_not_of(' ');
    if (lead != std::string_view::npos) ParseItem(item.substr(lead), static_cast<int64_t>(b + lead) + 1, r);
    b = i + 1;
  }
}

std::vector<Record> SrtParser::Parse() {
  std::vector<Record> records;
  bool in_record = false;
  while (NextLine()) {
    const std::string_view t = Trim(line_);
    if (t.empty()) {
      in_record = false;
      continue;
    }
    if (IsIndexLine(t)) {  // a subtitle number starts a record (also without the blank line before it)
      Record r;
      r.line = line_no_;
      flightlog::ParseInt64(t, &r.index);
      records.push_back(std::move(r));
      in_record = true;
      continue;
    }
    if (!in_record)
      Fail(line_no_, 1,
           records.empty()
               ? "not a DJI SRT file: expected a subtitle number, got '" + std::string(t.substr(0, 40)) + "'"
               : "expected a subtitle number after the blank line, got '" + std::string(t.substr(0, 40)) + "'");
    if (t.find("-->") != std::string_view::npos)
      ParseTimecode(line_, &records.back());
    else
      ParsePayload(line_, &records.back());
  }
  if (in_.bad()) throw InputError(InputLocation::File(path_), "read error");
  if (records.empty()) Fail(1, -1, "empty file: no SRT subtitles");
  return records;
}

/// Which way GPS(a, b, ...) is written in this file.
struct GpsOrder {
  bool lon_first = true;
  std::string reason;
};

double Dist2(double lat1, double lon1, double lat2, double lon2) {
  const double dlon = (lon1 - lon2) * std::cos(lat1 * M_PI / 180);
  return (lat1 - lat2) * (lat1 - lat2) + dlon * dlon;
}

GpsOrder DecideGpsOrder(const std::vector<Record>& recs, const std::string& path) {
  const Record* a_big = nullptr;  // first record whose first value can only be a longitude
  const Record* b_big = nullptr;
  bool unit_third = false;
  double tag_lat = kNaN, tag_lon = kNaN;
  for (const Record& r : recs) {
    for (const GpsCall* g : {&r.gps, &r.home}) {
      if (!g->present || g->not_available) continue;
      if (std::abs(g->a) > 90 && !a_big) a_big = &r;
      if (std::abs(g->b) > 90 && !b_big) b_big = &r;
    }
    if (r.gps.present && !r.gps.third.empty() && (r.gps.third.back() == 'M' || r.gps.third.back() == 'm'))
      unit_third = true;
    if (r.tag_lat.Has() && r.tag_lon.Has() && std::isnan(tag_lat)) tag_lat = r.tag_lat.v, tag_lon = r.tag_lon.v;
  }
  if (a_big && b_big)
    throw InputError(InputLocation::Line(path, b_big->gps.line, b_big->gps.column),
                     "GPS(...) value order is inconsistent: line " + std::to_string(a_big->gps.line) +
                         " has a first value beyond +-90 (a longitude) but this one has a second value beyond +-90");
  if (a_big) return {true, "(lon, lat): a first value beyond +-90 degrees at line " + std::to_string(a_big->gps.line)};
  if (b_big)
    return {false, "(lat, lon): a second value beyond +-90 degrees at line " + std::to_string(b_big->gps.line)};
  if (!std::isnan(tag_lat)) {  // mixed file: the tagged records say where the drone is
    for (const Record& r : recs) {
      if (!r.gps.present || r.gps.not_available) continue;
      const bool lon_first = Dist2(tag_lat, tag_lon, r.gps.b, r.gps.a) <= Dist2(tag_lat, tag_lon, r.gps.a, r.gps.b);
      return {lon_first, std::string(lon_first ? "(lon, lat)" : "(lat, lon)") +
                             ": the reading nearer to the file's [latitude]/[longitude] records"};
    }
  }
  if (unit_third)
    return {false,
            "(lat, lon): ambiguous by magnitude; dialect default for GPS(x, y, altM) (Matrice/Enterprise firmware)"};
  return {true, "(lon, lat): ambiguous by magnitude; dialect default for GPS(x, y, n) (DJI GO firmware)"};
}

// Completeness: a record without any position is a truncated record (or a camera-only file).
void CheckPositions(const std::vector<Record>& recs, const std::string& path) {
  const bool any_position = std::any_of(recs.begin(), recs.end(), [](const Record& r) { return r.HasPosition(); });
  if (!any_position)
    throw InputError(InputLocation::Line(path, recs.front().line),
                     "none of the " + std::to_string(recs.size()) +
                         " subtitles has a GPS position (truncated, or a camera that writes exposure only)");
  for (const Record& r : recs) {
    if (!r.HasPosition())
      throw InputError(InputLocation::Line(path, r.line),
                       "subtitle " + std::to_string(r.index) + " has no GPS position (truncated or corrupt record)");
    if (r.tag_lat.Has() != r.tag_lon.Has())
      throw InputError(InputLocation::Line(path, r.line),
                       "subtitle " + std::to_string(r.index) + " has a " +
                           (r.tag_lat.Has() ? "latitude but no longitude" : "longitude but no latitude") +
                           " (truncated record?)");
  }
}

// Time: the video clock where every record has a timecode, else date-times relative to the first
// dated record; the notes say which. Returns that first dated record (nullptr when none).
const Record* ChooseTimeBase(const std::vector<Record>& recs, const std::string& path, bool* all_timecode_out,
                             FlightTrack* track_out) {
  FlightTrack& track = *track_out;
  const bool all_timecode =
      std::all_of(recs.begin(), recs.end(), [](const Record& r) { return r.timecode_ns.has_value(); });
  const bool all_datetime =
      std::all_of(recs.begin(), recs.end(), [](const Record& r) { return r.datetime_ns.has_value(); });
  if (!all_timecode && !all_datetime) {
    for (const Record& r : recs)
      if (!r.timecode_ns && !r.datetime_ns)
        throw InputError(InputLocation::Line(path, r.line),
                         "subtitle " + std::to_string(r.index) + " has neither a timecode nor a date-time");
    throw InputError(InputLocation::Line(path, recs.front().line),
                     "subtitles mix timecodes and date-times with neither on every record");
  }
  const Record* first_dated = nullptr;
  for (const Record& r : recs)
    if (r.datetime_ns) {
      first_dated = &r;
      break;
    }
  if (all_timecode) {
    track.notes.push_back(
        "t_ns is the subtitle start time on the video clock (origin: start of the video); DJI SRT has no UTC");
  } else {
    track.notes.push_back(
        "t_ns is the record date-time minus the first record's (no subtitle timecodes); DJI writes camera local time "
        "without a zone");
  }
  if (first_dated) {
    // Restated so a caller who knows the time zone can map the track to UTC.
    track.notes.push_back("first record's date-time (camera local time, zone not recorded): " +
                          flightlog::FormatIsoNs(*first_dated->datetime_ns) + " at t_ns " +
                          std::to_string(all_timecode ? *first_dated->timecode_ns : 0));
  }

  *all_timecode_out = all_timecode;
  return first_dated;
}

// Altitude: absolute (AMSL) where the firmware gives it, else height above take-off.
void SetAltitude(const Record& r, GnssFix* f) {
  if (r.abs_alt.Has())
    f->alt_m = r.abs_alt.v, f->alt_ref = AltitudeReference::kAmsl;
  else if (r.altitude.Has())
    f->alt_m = r.altitude.v, f->alt_ref = AltitudeReference::kAmsl;
  else if (r.h.Has())
    f->alt_m = r.h.v, f->alt_ref = AltitudeReference::kTakeoff;
  else if (r.barometer.Has())
    f->alt_m = r.barometer.v, f->alt_ref = AltitudeReference::kTakeoff;
  else if (r.hb.Has())
    f->alt_m = r.hb.v, f->alt_ref = AltitudeReference::kTakeoff;
  else if (r.rel_alt.Has())
    f->alt_m = r.rel_alt.v, f->alt_ref = AltitudeReference::kTakeoff;
}

}  // namespace

FlightTrack ReadDjiSrt(std::istream& in, const std::string& path) {
  SrtParser parser(in, path);
  const std::vector<Record> recs = parser.Parse();

  FlightTrack track;
  track.source_path = path;
  track.format = "dji-srt";
  track.time_base = TimeBase::kBoot;

  CheckPositions(recs, path);
  bool all_timecode = false;
  const Record* first_dated = ChooseTimeBase(recs, path, &all_timecode, &track);

  const bool any_call =
      std::any_of(recs.begin(), recs.end(), [](const Record& r) { return r.gps.present && !r.gps.not_available; });
  GpsOrder order;
  if (any_call) {
    order = DecideGpsOrder(recs, path);
    track.notes.push_back("GPS(...) read as " + order.reason);
  }

  int64_t dropped_na = 0, n_amsl = 0, n_takeoff = 0, n_none = 0, ignored_gps_alt = 0;
  bool home_noted = false;
  for (const Record& r : recs) {
    GnssFix f;
    f.t_ns = all_timecode ? *r.timecode_ns : *r.datetime_ns - *first_dated->datetime_ns;
    int64_t line = r.line, col = -1;
    if (r.tag_lat.Has()) {
      f.lat_deg = r.tag_lat.v;
      f.lon_deg = r.tag_lon.v;
      line = r.tag_lat.line, col = r.tag_lat.column;
    } else if (r.gps.not_available) {
      ++dropped_na;
      continue;
    } else {
      f.lat_deg = order.lon_first ? r.gps.b : r.gps.a;
      f.lon_deg = order.lon_first ? r.gps.a : r.gps.b;
      line = r.gps.line, col = r.gps.column;
      if (!r.gps.third.empty()) {
        int64_t n;
        if (flightlog::ParseInt64(r.gps.third, &n) && n >= 0 && n <= 99)
          f.satellites = static_cast<int>(n);
        else
          ++ignored_gps_alt;
      }
    }
    if (std::abs(f.lat_deg) > 90 || std::abs(f.lon_deg) > 180)
      throw InputError(InputLocation::Line(path, line, col), "position out of range: lat " +
                                                                 flightlog::FormatDouble(f.lat_deg) + ", lon " +
                                                                 flightlog::FormatDouble(f.lon_deg));
    if (f.lat_deg == 0 && f.lon_deg == 0) {  // DJI writes 0,0 before the first fix
      ++dropped_na;
      continue;
    }
    SetAltitude(r, &f);
    if (std::isnan(f.alt_m))
      ++n_none;
    else if (f.alt_ref == AltitudeReference::kAmsl)
      ++n_amsl;
    else
      ++n_takeoff;
    if (r.speed.Has()) {
      if (r.speed.v < 0)
        throw InputError(InputLocation::Line(path, r.speed.line, r.speed.column), "negative horizontal speed");
      f.ground_speed_m_s = r.speed.v;
    }
    track.fixes.push_back(f);
    if (r.has_pry)
      track.attitude.push_back(flightlog::AttitudeFromEulerDeg(f.t_ns, r.roll_deg, r.pitch_deg, r.yaw_deg));
    if (r.home.present && !r.home.not_available && !home_noted) {
      const double hlat = order.lon_first ? r.home.b : r.home.a, hlon = order.lon_first ? r.home.a : r.home.b;
      track.notes.push_back("home point: lat " + flightlog::FormatDouble(hlat) + ", lon " +
                            flightlog::FormatDouble(hlon));
      home_noted = true;
    }
  }
  if (dropped_na > 0)
    track.notes.push_back(std::to_string(dropped_na) + " subtitles without a GPS fix (N/A or 0,0) dropped");
  if (n_amsl > 0)
    track.notes.push_back(std::to_string(n_amsl) + " fixes: altitude from abs_alt/altitude tags, taken as AMSL");
  if (n_takeoff > 0)
    track.notes.push_back(std::to_string(n_takeoff) +
                          " fixes: altitude from H/BAROMETER/Hb/rel_alt, height above take-off");
  if (n_none > 0) track.notes.push_back(std::to_string(n_none) + " fixes without altitude");
  if (ignored_gps_alt > 0)
    track.notes.push_back(
        std::to_string(ignored_gps_alt) +
        " GPS(...) third values with a unit ignored (altitude of undocumented datum; BAROMETER used)");
  if (!track.attitude.empty()) track.notes.push_back("attitude from F.PRY (aircraft pitch, roll, yaw in degrees)");
  if (track.fixes.empty())
    throw InputError(InputLocation::Line(path, recs.front().line), "no subtitle has a GPS fix (all N/A)");
  flightlog::SortTrackByTime(&track);
  return track;
}

FlightTrack ReadDjiSrt(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadDjiSrt(in, path.string());
}

}  // namespace rs
