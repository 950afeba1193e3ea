// roadsurvey log FILE: what roadsurvey understood from a flight log (any supported format),
// and optionally the normalized track as roadsurvey track CSV.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <functional>
#include <map>
#include <memory>
#include <sstream>

#include <GeographicLib/Geodesic.hpp>

#include "cli/command.h"
#include "cli/tool_util.h"
#include "formats/flight_log/flight_log.h"
#include "formats/flight_log/track_csv.h"

namespace rs {
namespace {

/// "2023-05-01T12:00:00.123Z" for UTC, "+12.345 s" since the log's origin otherwise.
std::string FormatTime(int64_t t_ns, TimeBase base) {
  if (base != TimeBase::kUtc) return fmt::format("{:.3f} s (since the log's own origin, no UTC)", t_ns * 1e-9);
  int64_t s = t_ns / 1'000'000'000, ns = t_ns % 1'000'000'000;
  if (ns < 0) ns += 1'000'000'000, --s;
  const std::time_t tt = static_cast<std::time_t>(s);
  std::tm tm{};
  if (!gmtime_r(&tt, &tm)) return fmt::format("{} ns", t_ns);
  return fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.{:03d}Z", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                     tm.tm_hour, tm.tm_min, tm.tm_sec, int(ns / 1'000'000));
}

std::string FixTypeName(int t) {
  switch (t) {
    case -1: return "unknown";
    case 0: return "none";
    case 1: return "no fix (1)";
    case 2: return "2D";
    case 3: return "3D";
    case 4: return "DGPS";
    case 5: return "RTK float";
    case 6: return "RTK fixed";
    default: return fmt::format("type {}", t);
  }
}

template <class K>
std::string Histogram(const std::map<K, int>& counts, const std::function<std::string(const K&)>& name) {
  std::string out;
  for (const auto& [k, n] : counts) out += fmt::format("{}{}: {}", out.empty() ? "" : ", ", name(k), n);
  return out.empty() ? "-" : out;
}

}  // namespace

Command LogCommand() {
  return {"log", "Show what roadsurvey reads from a flight log (format, time base, fixes, events); export as CSV",
          [](CLI::App& app, const StageRegistry&) -> std::function<int()> {
            app.option_defaults()->always_capture_default();
            struct Args {
              std::string path, format = "auto", csv;
            };
            auto a = std::make_shared<Args>();
            app.add_option("log", a->path, "flight log file (or KITTI OXTS folder)")->required();
            app.add_option("--format", a->format, "log format (auto: detected from the content)")
                ->check(CLI::IsMember(
                    {"auto", "csv", "airdata-csv", "gpx", "px4-ulog", "ardupilot-dataflash", "dji-srt", "kitti-oxts"}));
            app.add_option("--csv", a->csv, "write the normalized track as roadsurvey track CSV ('-' = stdout)");
            return [a] {
              const std::string format = a->format == "auto" ? DetectFlightLogFormat(a->path) : a->format;
              const FlightTrack track = ReadFlightLog(a->path, format);
              if (a->csv == "-") {  // the CSV alone on stdout, so it can be piped
                std::ostringstream out;
                WriteTrackCsv(out, track);
                WriteTextOutput("-", out.str());
                return kExitOk;
              }
              fmt::print("file            {}\n", a->path);
              fmt::print("format          {}{}\n", track.format, a->format == "auto" ? " (detected)" : "");
              fmt::print("time base       {}\n", track.time_base == TimeBase::kUtc
                                                     ? "UTC (ns since the Unix epoch)"
                                                     : "boot/relative (no UTC mapping in the log)");
              int64_t t0 = INT64_MAX, t1 = INT64_MIN;
              auto span = [&](int64_t t) { t0 = std::min(t0, t), t1 = std::max(t1, t); };
              for (const auto& f : track.fixes) span(f.t_ns);
              for (const auto& s : track.attitude) span(s.t_ns);
              for (const auto& e : track.camera_events) span(e.t_ns);
              if (t0 <= t1)
                fmt::print("span            {} .. {} ({:.3f} s)\n", FormatTime(t0, track.time_base),
                           FormatTime(t1, track.time_base), (t1 - t0) * 1e-9);
              else
                fmt::print("span            - (no records)\n");

              std::map<int, int> fix_types;
              std::map<AltitudeReference, int> alt_refs;
              int positioned = 0;
              double lat_min = 90, lat_max = -90, lon_min = 180, lon_max = -180, path_m = 0, max_speed = 0,
                     max_logged_speed = -1, alt_min = INFINITY, alt_max = -INFINITY;
              const GnssFix* prev = nullptr;
              const GeographicLib::Geodesic& wgs84 = GeographicLib::Geodesic::WGS84();
              for (const auto& f : track.fixes) {
                fix_types[f.fix_type]++;
                alt_refs[f.alt_ref]++;
                if (std::isfinite(f.ground_speed_m_s))
                  max_logged_speed = std::max(max_logged_speed, f.ground_speed_m_s);
                if (std::isfinite(f.alt_m)) alt_min = std::min(alt_min, f.alt_m), alt_max = std::max(alt_max, f.alt_m);
                if (!std::isfinite(f.lat_deg) || !std::isfinite(f.lon_deg)) continue;
                ++positioned;
                lat_min = std::min(lat_min, f.lat_deg), lat_max = std::max(lat_max, f.lat_deg);
                lon_min = std::min(lon_min, f.lon_deg), lon_max = std::max(lon_max, f.lon_deg);
                if (prev) {
                  double s12 = 0;
                  wgs84.Inverse(prev->lat_deg, prev->lon_deg, f.lat_deg, f.lon_deg, s12);
                  path_m += s12;
                  if (f.t_ns > prev->t_ns) max_speed = std::max(max_speed, s12 / ((f.t_ns - prev->t_ns) * 1e-9));
                }
                prev = &f;
              }
              fmt::print("fixes           {} ({} with a position)\n", track.fixes.size(), positioned);
              fmt::print("fix types       {}\n",
                         Histogram<int>(fix_types, [](const int& t) { return FixTypeName(t); }));
              fmt::print("altitude ref    {}\n", Histogram<AltitudeReference>(alt_refs, [](const AltitudeReference& r) {
                           return std::string(ToString(r));
                         }));
              if (alt_min <= alt_max) fmt::print("altitude        {:.2f} .. {:.2f} m\n", alt_min, alt_max);
              fmt::print("attitude        {} samples\n", track.attitude.size());
              fmt::print("camera events   {}\n", track.camera_events.size());
              if (positioned > 0) {
                fmt::print("bounding box    lat {:.7f} .. {:.7f} deg, lon {:.7f} .. {:.7f} deg\n", lat_min, lat_max,
                           lon_min, lon_max);
                fmt::print("path length     {:.2f} m (geodesic, WGS84)\n", path_m);
                fmt::print("max speed       {:.2f} m/s between consecutive fixes{}\n", max_speed,
                           max_logged_speed >= 0 ? fmt::format(", {:.2f} m/s logged", max_logged_speed) : "");
              }
              fmt::print("notes           {}\n", track.notes.empty() ? "-" : "");
              for (const auto& n : track.notes) fmt::print("  {}\n", n);
              if (!a->csv.empty()) {
                std::ostringstream out;
                WriteTrackCsv(out, track);
                WriteTextOutput(a->csv, out.str());
                fmt::print("wrote           {}\n", a->csv);
              }
              return kExitOk;
            };
          }};
}

}  // namespace rs
