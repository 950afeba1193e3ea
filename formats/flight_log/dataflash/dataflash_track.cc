#include "formats/flight_log/dataflash/dataflash_track.h"
#include "formats/flight_log/track_sort.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>

#include <fmt/format.h>

#include "formats/flight_log/dataflash/gps_time.h"
#include "formats/input_error.h"

namespace rs {
namespace {

using dataflash::MessageType;

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Boot-time column of a message: TimeUS (us); TimeMS (ms) unless it holds GPS
// time of week (old GPS messages, which carry boot ms in "T" instead).
struct BootClock {
  std::optional<size_t> col;
  int64_t us_per_unit = 1;
};

BootClock FindBootClock(const MessageType& m) {
  if (auto c = m.ColumnIndex("TimeUS")) return {c, 1};
  if (!m.ColumnIndex("Week")) {
    if (auto c = m.ColumnIndex("TimeMS")) return {c, 1000};
  }
  if (auto c = m.ColumnIndex("T")) return {c, 1000};
  return {};
}

// Boot times beyond ~30 years are corrupt; refusing them also keeps every
// nanosecond computation far from int64 overflow.
constexpr int64_t kMaxBootUs = 1000000000000000LL;

std::optional<int64_t> BootUs(const MessageType& m, const BootClock& clk, size_t row) {
  if (!clk.col) return std::nullopt;
  const int64_t v = m.Int(row, *clk.col);
  if (v < 0 || v > kMaxBootUs / clk.us_per_unit) return std::nullopt;
  return v * clk.us_per_unit;
}

// GPS week and ms-of-week columns: GWk/GMS (since 2015), Week/TimeMS (older).
struct GpsClock {
  std::optional<size_t> week, ms;
};

GpsClock FindGpsClock(const MessageType& m, const char* week_name, const char* ms_name) {
  GpsClock c;
  c.week = m.ColumnIndex(week_name);
  c.ms = m.ColumnIndex(ms_name);
  if (!c.week || !c.ms) {
    c.week = m.ColumnIndex("GWk");
    c.ms = m.ColumnIndex("GMS");
  }
  if (!c.week || !c.ms) {
    c.week = m.ColumnIndex("Week");
    c.ms = m.ColumnIndex("TimeMS");
  }
  if (!c.week || !c.ms) return {};
  return c;
}

std::optional<int64_t> GpsUtcNs(const MessageType& m, const GpsClock& c, size_t row) {
  if (!c.week) return std::nullopt;
  const int64_t week = m.Int(row, *c.week), ms = m.Int(row, *c.ms);
  if (week <= 0) return std::nullopt;  // receiver has no time yet
  return dataflash::GpsWeekMsToUtcNs(week, ms);
}

std::optional<dataflash::BootClockFit> FitClock(const std::vector<std::pair<int64_t, int64_t>>& pairs) {
  if (pairs.empty()) return std::nullopt;
  dataflash::BootClockFit fit;
  fit.boot0 = pairs.front().first;
  fit.utc0 = pairs.front().second;
  std::vector<char> use(pairs.size(), 1);
  for (int pass = 0; pass < 2; ++pass) {
    double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      if (!use[i]) continue;
      const double x = static_cast<double>(pairs[i].first - fit.boot0),
                   y = static_cast<double>(pairs[i].second - fit.utc0);
      n += 1;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
    if (n == 0) return std::nullopt;
    const double var = sxx - sx * sx / n;
    // Under 10 s of data cannot pin down a rate: assume the clocks tick alike.
    fit.rate = var > n * 1e20 ? (sxy - sx * sy / n) / var : 1.0;
    fit.offset_ns = (sy - fit.rate * sx) / n;
    fit.max_residual_s = 0;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const double res = std::fabs(static_cast<double>(fit.ToUtcNs(pairs[i].first) - pairs[i].second)) * 1e-9;
      if (pass == 0 && res > 1.0) use[i] = 0;  // a GPS time glitch, not clock drift
      if (use[i]) fit.max_residual_s = std::max(fit.max_residual_s, res);
    }
  }
  if (!(fit.rate > 0.5 && fit.rate < 1.5) || !(std::fabs(fit.offset_ns) < 1e18)) return std::nullopt;  // not a clock
  return fit;
}

AttitudeSample FromEulerDeg(int64_t t_ns, double roll_deg, double pitch_deg, double yaw_deg) {
  // ZYX (yaw, pitch, roll) Euler angles of body FRD in NED: q = Rz(yaw) Ry(pitch) Rx(roll).
  const double r = roll_deg * kDegToRad / 2, p = pitch_deg * kDegToRad / 2, y = yaw_deg * kDegToRad / 2;
  const double cr = std::cos(r), sr = std::sin(r), cp = std::cos(p), sp = std::sin(p), cy = std::cos(y),
               sy = std::sin(y);
  AttitudeSample a;
  a.t_ns = t_ns;
  a.qw = cr * cp * cy + sr * sp * sy;
  a.qx = sr * cp * cy - cr * sp * sy;
  a.qy = cr * sp * cy + sr * cp * sy;
  a.qz = cr * cp * sy - sr * sp * cy;
  return a;
}

}  // namespace

namespace dataflash {

std::optional<BootClockFit> FitBootClock(const DataflashFile& log) {
  const MessageType* gps = log.Find("GPS");
  if (!gps) return std::nullopt;
  const auto inst = gps->ColumnIndex("I");
  const auto status = gps->ColumnIndex("Status");
  const BootClock bc = FindBootClock(*gps);
  const GpsClock gc = FindGpsClock(*gps, "GWk", "GMS");
  std::vector<std::pair<int64_t, int64_t>> pairs;  // (boot ns, UTC ns)
  std::optional<int64_t> prev_utc;
  for (size_t r = 0; r < gps->size(); ++r) {
    if ((inst && gps->Int(r, *inst) != 0) || (status && gps->Int(r, *status) < 3)) continue;
    const auto boot = BootUs(*gps, bc, r);
    const auto utc = GpsUtcNs(*gps, gc, r);
    // Only the first record of each GPS time: later ones re-log a stale fix.
    if (!boot || !utc || *boot <= 0 || (prev_utc && *utc == *prev_utc)) continue;
    prev_utc = utc;
    pairs.emplace_back(*boot * 1000, *utc);
  }
  auto fit = FitClock(pairs);
  if (fit) fit->pairs = static_cast<int>(pairs.size());
  return fit;
}

}  // namespace dataflash

namespace {

/// Notes on the boot->UTC fit, and on a boot clock whose rate is visibly off.
void AddClockNotes(const std::optional<dataflash::BootClockFit>& clock, FlightTrack* track) {
  if (!clock) return;
  track->notes.push_back(
      fmt::format("UTC from GPS week/ms (GPS-UTC leap seconds applied): boot clock fitted over {} 3D fixes, "
                  "rate {:.6f}, max residual {:.3f} s",
                  clock->pairs, clock->rate, clock->max_residual_s));
  if (std::fabs(clock->rate - 1) > 1e-3) {
    track->notes.push_back(fmt::format("boot clock runs {:.2f} % {} than GPS time", std::fabs(clock->rate - 1) * 100,
                                       clock->rate > 1 ? "slower" : "faster"));
  }
}

/// A boot time (us) on the track's clock: UTC through the fit where there is one, else boot ns.
std::optional<int64_t> TrackNs(const std::optional<dataflash::BootClockFit>& clock, std::optional<int64_t> boot_us) {
  if (!boot_us) return std::nullopt;
  return clock ? clock->ToUtcNs(*boot_us * 1000) : *boot_us * 1000;
}

/// GNSS fixes from the primary GPS instance, timed by their own GPS time where
/// the clock is fitted; re-logged, timeless or fix-less records are dropped and counted.
void AddFixes(const dataflash::DataflashFile& log, const std::optional<dataflash::BootClockFit>& clock,
              FlightTrack* track) {
  const MessageType* gps = log.Find("GPS");
  if (!gps) return;
  const auto inst = gps->ColumnIndex("I");
  auto primary = [&](size_t row) { return !inst || gps->Int(row, *inst) == 0; };
  const auto status = gps->ColumnIndex("Status");
  const BootClock bc = FindBootClock(*gps);
  const auto lat = gps->ColumnIndex("Lat"), lng = gps->ColumnIndex("Lng"), alt = gps->ColumnIndex("Alt");
  const auto sats = gps->ColumnIndex("NSats"), spd = gps->ColumnIndex("Spd");
  if (!lat || !lng || !bc.col) {
    track->notes.push_back("GPS message lacks Lat/Lng or a time column: no fixes");
  } else {
    const GpsClock gc = FindGpsClock(*gps, "GWk", "GMS");
    int dropped = 0, total = 0, repeats = 0;
    std::optional<int64_t> prev_utc;
    for (size_t r = 0; r < gps->size(); ++r) {
      if (!primary(r)) continue;
      ++total;
      GnssFix f;
      // A fix's own epoch is its GPS time; the boot column is when it was
      // logged, and old firmware re-logs the last fix until a new one arrives.
      const auto utc = clock ? GpsUtcNs(*gps, gc, r) : std::nullopt;
      if (utc && prev_utc && *utc == *prev_utc) {
        ++repeats;
        continue;
      }
      if (utc) prev_utc = utc;
      const auto t = utc ? utc : TrackNs(clock, BootUs(*gps, bc, r));
      if (!t) {
        ++dropped;
        continue;
      }
      f.t_ns = *t;
      f.lat_deg = gps->Value(r, *lat);
      f.lon_deg = gps->Value(r, *lng);
      if (status) f.fix_type = static_cast<int>(gps->Int(r, *status));
      if ((status && f.fix_type < 2) || std::fabs(f.lat_deg) > 90 || std::fabs(f.lon_deg) > 180 ||
          (f.lat_deg == 0 && f.lon_deg == 0)) {
        ++dropped;
        continue;
      }
      if (alt) {
        f.alt_m = gps->Value(r, *alt);
        f.alt_ref = AltitudeReference::kAmsl;
      }
      if (sats) f.satellites = static_cast<int>(gps->Int(r, *sats));
      if (spd) f.ground_speed_m_s = gps->Value(r, *spd);
      f.source_pos = gps->offsets[r];
      track->fixes.push_back(f);
    }
    if (dropped > 0) track->notes.push_back(fmt::format("dropped {} of {} GPS records without a fix", dropped, total));
    if (repeats > 0)
      track->notes.push_back(fmt::format("dropped {} GPS records repeating the previous fix's GPS time", repeats));
    if (inst) track->notes.push_back("GPS: instance 0 (primary) used");
  }
  if (log.Find("GPS2")) track->notes.push_back("GPS2 (second receiver) present, not used");
}

/// Attitude from ATT (or AHR2 where ATT has no angles); records without a valid time are dropped and counted.
void AddAttitude(const dataflash::DataflashFile& log, const std::optional<dataflash::BootClockFit>& clock,
                 FlightTrack* track) {
  const MessageType* att = log.Find("ATT");
  if (!att || !att->ColumnIndex("Roll")) att = log.Find("AHR2");
  if (!att) return;
  const BootClock bc = FindBootClock(*att);
  const auto roll = att->ColumnIndex("Roll"), pitch = att->ColumnIndex("Pitch"), yaw = att->ColumnIndex("Yaw");
  if (!roll || !pitch || !yaw || !bc.col) return;
  int dropped = 0;
  for (size_t r = 0; r < att->size(); ++r) {
    const auto t = TrackNs(clock, BootUs(*att, bc, r));
    if (!t) {
      ++dropped;
      continue;
    }
    track->attitude.push_back(FromEulerDeg(*t, att->Value(r, *roll), att->Value(r, *pitch), att->Value(r, *yaw)));
    track->attitude.back().source_pos = att->offsets[r];
  }
  if (dropped > 0)
    track->notes.push_back(fmt::format("dropped {} {} records with an invalid time", dropped, att->name));
  track->notes.push_back(fmt::format("attitude from {}", att->name));
}

/// Camera events from CAM (or TRIG), timed by boot time, else by their GPS time
/// when the clock is fitted; the altitude column says which reference it carries.
void AddCameraEvents(const dataflash::DataflashFile& log, const std::optional<dataflash::BootClockFit>& clock,
                     FlightTrack* track) {
  const MessageType* cam = log.Find("CAM");
  if (!cam) cam = log.Find("TRIG");
  if (!cam) return;
  const BootClock bc = FindBootClock(*cam);
  const GpsClock gc = FindGpsClock(*cam, "GPSWeek", "GPSTime");
  const auto img = cam->ColumnIndex("Img");
  const auto lat = cam->ColumnIndex("Lat"), lng = cam->ColumnIndex("Lng");
  std::optional<size_t> alt;
  AltitudeReference ref = AltitudeReference::kUnknown;
  if ((alt = cam->ColumnIndex("GPSAlt"))) {
    ref = AltitudeReference::kAmsl;
  } else if ((alt = cam->ColumnIndex("RelAlt"))) {
    ref = AltitudeReference::kTakeoff;
  } else {
    alt = cam->ColumnIndex("Alt");
  }
  int dropped = 0;
  for (size_t r = 0; r < cam->size(); ++r) {
    CameraEvent e;
    if (auto boot = TrackNs(clock, BootUs(*cam, bc, r))) {
      e.t_ns = *boot;
    } else if (auto utc = GpsUtcNs(*cam, gc, r); utc && clock) {
      e.t_ns = *utc;
    } else {
      ++dropped;
      continue;
    }
    if (img) e.sequence = cam->Int(r, *img);
    if (lat && lng) {
      e.lat_deg = cam->Value(r, *lat);
      e.lon_deg = cam->Value(r, *lng);
    }
    if (alt) {
      e.alt_m = cam->Value(r, *alt);
      e.alt_ref = ref;
    }
    e.source_pos = cam->offsets[r];
    track->camera_events.push_back(e);
  }
  track->notes.push_back(fmt::format("camera events from {}", cam->name));
  if (dropped > 0)
    track->notes.push_back(fmt::format("dropped {} {} records without a usable time", dropped, cam->name));
}

/// Notes on what the file reader skipped or could not use, so a damaged log says so.
void AddFileNotes(const dataflash::DataflashFile& log, FlightTrack* track) {
  if (log.skipped_bytes > 0) {
    std::string where;
    for (size_t i = 0; i < log.skips.size() && i < 5; ++i) {
      where += fmt::format("{}{} bytes at byte {} ({})", i ? "; " : "", log.skips[i].bytes, log.skips[i].offset,
                           log.skips[i].reason);
    }
    track->notes.push_back(fmt::format("skipped {} bytes in {} runs: {}{}", log.skipped_bytes, log.skip_runs, where,
                                       log.skip_runs > 5 ? "; ..." : ""));
  }
  if (log.rejected_formats > 0) {
    track->notes.push_back(
        fmt::format("{} FMT definitions unusable (unknown format characters or bad length)", log.rejected_formats));
  }
}

}  // namespace

FlightTrack DataflashToFlightTrack(const dataflash::DataflashFile& log, const std::string& path) {
  FlightTrack track;
  track.source_path = path;
  track.format = "ardupilot-dataflash";

  // Boot -> UTC: a linear fit over GPS records that carry both clocks. Some
  // boards' boot clock runs measurably slow or fast (the 2014 PXF logs: ~8 %),
  // so a constant offset is not enough.
  const std::optional<dataflash::BootClockFit> clock = dataflash::FitBootClock(log);
  AddClockNotes(clock, &track);
  track.time_base = clock ? TimeBase::kUtc : TimeBase::kBoot;
  if (!clock) track.notes.push_back("no GPS week/ms with a 3D fix: t_ns is time since autopilot boot");

  AddFixes(log, clock, &track);
  AddAttitude(log, clock, &track);
  AddCameraEvents(log, clock, &track);

  flightlog::SortTrackByTime(&track);
  AddFileNotes(log, &track);
  return track;
}

FlightTrack ReadDataflashTrack(std::istream& in, const std::string& path) {
  return DataflashToFlightTrack(dataflash::ReadDataflashFile(in, path), path);
}

FlightTrack ReadDataflashTrack(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadDataflashTrack(in, path.string());
}

}  // namespace rs
