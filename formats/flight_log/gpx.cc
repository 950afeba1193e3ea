#include "formats/flight_log/gpx.h"

#include <pugixml.hpp>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <istream>
#include <iterator>

#include "formats/flight_log/flight_log_text.h"
#include "formats/flight_log/time_parse.h"
#include "formats/flight_log/track_sort.h"
#include "formats/input_error.h"

namespace rs {
namespace {

constexpr size_t kMaxGpxBytes = size_t{1} << 30;
constexpr int64_t kGpsEpochNs = 315964800LL * 1000000000LL;  // 1980-01-06T00:00:00Z

/// Maps byte offsets of the XML buffer to 1-based line:column.
class LineIndex {
 public:
  explicit LineIndex(const std::string& buf) {
    starts_.push_back(0);
    for (size_t i = 0; i < buf.size(); ++i)
      if (buf[i] == '\n') starts_.push_back(i + 1);
  }
  InputLocation At(const std::string& path, ptrdiff_t offset) const {
    if (offset < 0) return InputLocation::File(path);
    const auto it = std::upper_bound(starts_.begin(), starts_.end(), static_cast<size_t>(offset));
    const size_t line = static_cast<size_t>(it - starts_.begin());
    return InputLocation::Line(path, static_cast<int64_t>(line),
                               offset - static_cast<ptrdiff_t>(starts_[line - 1]) + 1);
  }

 private:
  std::vector<size_t> starts_;
};

/// Element name without a namespace prefix ("gpx:trkpt" -> "trkpt").
std::string_view LocalName(const pugi::xml_node& n) {
  std::string_view s = n.name();
  const size_t c = s.find(':');
  return c == std::string_view::npos ? s : s.substr(c + 1);
}

pugi::xml_node Child(const pugi::xml_node& n, std::string_view name) {
  for (pugi::xml_node c = n.first_child(); c; c = c.next_sibling())
    if (c.type() == pugi::node_element && LocalName(c) == name) return c;
  return {};
}

}  // namespace

FlightTrack ReadGpx(std::istream& in, const std::string& path) {
  std::string buf;
  {
    char chunk[65536];
    while (in.read(chunk, sizeof(chunk)) || in.gcount() > 0) {
      buf.append(chunk, static_cast<size_t>(in.gcount()));
      if (buf.size() > kMaxGpxBytes)
        throw InputError(InputLocation::File(path), "larger than 1 GiB: refusing to parse as GPX");
    }
    if (in.bad()) throw InputError(InputLocation::File(path), "read error");
  }
  const LineIndex lines(buf);
  pugi::xml_document doc;
  const pugi::xml_parse_result res = doc.load_buffer(buf.data(), buf.size(), pugi::parse_default, pugi::encoding_auto);
  if (!res) throw InputError(lines.At(path, res.offset), std::string("malformed XML: ") + res.description());
  // offset_debug() points at an element's name; step back to its '<'.
  auto loc = [&](const pugi::xml_node& n) {
    const ptrdiff_t off = n.offset_debug();
    return lines.At(path, off > 0 ? off - 1 : off);
  };

  const pugi::xml_node root = doc.document_element();
  if (!root || LocalName(root) != "gpx")
    throw InputError(root ? loc(root) : InputLocation::File(path), std::string("not a GPX file: root element is <") +
                                                                       (root ? root.name() : "") + ">, expected <gpx>");

  FlightTrack track;
  track.source_path = path;
  track.format = "gpx";
  const std::string version = root.attribute("version").as_string();
  if (version != "1.0" && version != "1.1")
    track.notes.push_back("GPX version attribute is '" + version + "' (expected 1.0 or 1.1); read as 1.1");

  // Collect points: tracks first, else routes, else waypoints.
  std::vector<pugi::xml_node> trkpts, rtepts, wpts;
  for (pugi::xml_node c = root.first_child(); c; c = c.next_sibling()) {
    if (c.type() != pugi::node_element) continue;
    const std::string_view name = LocalName(c);
    if (name == "trk") {
      for (pugi::xml_node seg = c.first_child(); seg; seg = seg.next_sibling())
        if (seg.type() == pugi::node_element && LocalName(seg) == "trkseg")
          for (pugi::xml_node p = seg.first_child(); p; p = p.next_sibling())
            if (p.type() == pugi::node_element && LocalName(p) == "trkpt") trkpts.push_back(p);
    } else if (name == "rte") {
      for (pugi::xml_node p = c.first_child(); p; p = p.next_sibling())
        if (p.type() == pugi::node_element && LocalName(p) == "rtept") rtepts.push_back(p);
    } else if (name == "wpt") {
      wpts.push_back(c);
    }
  }
  const std::vector<pugi::xml_node>* pts = &trkpts;
  const char* kind = "trkpt";
  if (trkpts.empty() && !rtepts.empty())
    pts = &rtepts, kind = "rtept";
  else if (trkpts.empty() && rtepts.empty())
    pts = &wpts, kind = "wpt";
  if (pts->empty()) throw InputError(loc(root), "GPX file has no track, route or waypoint points");
  track.notes.push_back("fixes from " + std::to_string(pts->size()) + " <" + kind + "> points");
  if (pts != &trkpts && !trkpts.empty()) track.notes.push_back(std::to_string(trkpts.size()) + " <trkpt> ignored");
  if (pts != &rtepts && !rtepts.empty())
    track.notes.push_back(std::to_string(rtepts.size()) + " <rtept> ignored (planned route, not the flown track)");
  if (pts != &wpts && !wpts.empty())
    track.notes.push_back(std::to_string(wpts.size()) + " <wpt> ignored (waypoints, not the flown track)");

  int64_t n_timed = 0, n_untimed = 0, n_no_zone = 0, n_no_ele = 0, n_sentinel = 0;
  std::vector<bool> timed;
  for (const pugi::xml_node& p : *pts) {
    GnssFix f;
    for (const char* attr : {"lat", "lon"}) {
      const pugi::xml_attribute a = p.attribute(attr);
      double v;
      if (!a) throw InputError(loc(p), std::string("<") + kind + "> lacks the " + attr + " attribute");
      if (!flightlog::ParseDouble(a.value(), &v))
        throw InputError(loc(p), std::string(attr) + "=\"" + a.value() + "\" is not a number");
      const double lim = attr[1] == 'a' ? 90.0 : 180.0;
      if (v < -lim || v > lim)
        throw InputError(loc(p), std::string(attr) + "=" + a.value() + " outside [-" + flightlog::FormatDouble(lim) +
                                     ", " + flightlog::FormatDouble(lim) + "]");
      (attr[1] == 'a' ? f.lat_deg : f.lon_deg) = v;
    }
    if (const pugi::xml_node ele = Child(p, "ele")) {
      if (!flightlog::ParseDouble(ele.child_value(), &f.alt_m) || f.alt_m < -1e5 || f.alt_m > 1e6)
        throw InputError(loc(ele), std::string("<ele> is not a plausible altitude: '") + ele.child_value() + "'");
      f.alt_ref = AltitudeReference::kAmsl;
    } else {
      ++n_no_ele;
    }
    if (const pugi::xml_node sat = Child(p, "sat")) {
      int64_t n;
      if (!flightlog::ParseInt64(sat.child_value(), &n) || n < 0 || n > 1000)
        throw InputError(loc(sat), std::string("<sat> is not a satellite count: '") + sat.child_value() + "'");
      f.satellites = static_cast<int>(n);
    }
    if (const pugi::xml_node fix = Child(p, "fix")) {
      const std::string v = flightlog::ToLowerAscii(flightlog::Trim(fix.child_value()));
      f.fix_type = v == "none" ? 0 : v == "2d" ? 2 : v == "3d" ? 3 : v == "dgps" ? 4 : -1;  // "pps" (military): unknown
    }
    if (const pugi::xml_node speed = Child(p, "speed")) {  // GPX 1.0: m/s
      if (!flightlog::ParseDouble(speed.child_value(), &f.ground_speed_m_s) || f.ground_speed_m_s < 0)
        throw InputError(loc(speed), std::string("<speed> is not a speed in m/s: '") + speed.child_value() + "'");
    }
    bool has_time = false;
    if (const pugi::xml_node time = Child(p, "time")) {
      bool has_zone = false;
      if (!flightlog::ParseIso8601(time.child_value(), &f.t_ns, &has_zone))
        throw InputError(loc(time), std::string("<time> is not an ISO-8601 date-time: '") + time.child_value() + "'");
      // Before the GPS epoch (1980-01-06) it is a "no time" sentinel, e.g. the
      // 1901-12-13T20:45:52 (int32 epoch minimum) some loggers write.
      if (f.t_ns < kGpsEpochNs) {
        ++n_sentinel;
      } else {
        n_no_zone += !has_zone;
        has_time = true;
      }
    }
    (has_time ? n_timed : n_untimed)++;
    timed.push_back(has_time);
    track.fixes.push_back(f);
  }

  if (n_sentinel > 0)
    track.notes.push_back(std::to_string(n_sentinel) +
                          " <time> values before 1980 (a logger's 'no time' sentinel) treated as missing");
  if (n_timed == 0) {
    track.time_base = TimeBase::kBoot;
    for (size_t i = 0; i < track.fixes.size(); ++i) track.fixes[i].t_ns = static_cast<int64_t>(i);
    track.notes.push_back(
        "no point has a <time>: the track has NO time; t_ns is the point's index in the file (0, 1, 2, ...)");
  } else {
    track.time_base = TimeBase::kUtc;
    if (n_untimed > 0) {
      std::vector<GnssFix> kept;
      for (size_t i = 0; i < track.fixes.size(); ++i)
        if (timed[i]) kept.push_back(track.fixes[i]);
      track.fixes = std::move(kept);
      track.notes.push_back(std::to_string(n_untimed) + " points without <time> dropped");
    }
    if (n_no_zone > 0)
      track.notes.push_back(std::to_string(n_no_zone) + " <time> values without a zone, taken as UTC (GPX spec)");
  }
  track.notes.push_back("<ele> taken as height above mean sea level (devices write MSL although GPX says WGS84)");
  if (n_no_ele > 0) track.notes.push_back(std::to_string(n_no_ele) + " points without <ele>");
  flightlog::SortTrackByTime(&track);
  return track;
}

FlightTrack ReadGpx(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadGpx(in, path.string());
}

}  // namespace rs
