#include "formats/flight_log/ulog/ulog_track.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>

#include <fmt/format.h>

#include "formats/input_error.h"

namespace rs {
namespace {

using ulog::Topic;

// Plausible GNSS UTC times: 2000-01-01 .. ~2096; receivers without time report 0.
constexpr int64_t kMinUtcUs = 946684800LL * 1000000LL;
constexpr uint64_t kMaxUs = 4000000000000000ULL;
// Timestamps beyond kMaxUs (SITL logs use Unix time as boot time, so boot
// times can be that large) are corrupt; refusing them keeps t_ns in int64.

std::optional<size_t> Field(const Topic& t, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    if (auto i = t.FieldIndex(n)) return i;
  }
  return std::nullopt;
}

bool IsIntegerField(const Topic& t, size_t i) {
  return t.fields[i].type != ulog::BaseType::kFloat && t.fields[i].type != ulog::BaseType::kDouble;
}

// Value in degrees: int32 fields are 1e-7 deg, floating fields are degrees.
double Degrees(const Topic& t, size_t row, size_t i) {
  return IsIntegerField(t, i) ? t.IntValue(row, i) * 1e-7 : t.Value(row, i);
}
// Value in metres: integer fields are millimetres (older vehicle_gps_position), floating fields metres.
double Metres(const Topic& t, size_t row, size_t i) {
  return IsIntegerField(t, i) ? t.IntValue(row, i) * 1e-3 : t.Value(row, i);
}

const Topic* FirstTopic(const ulog::UlogFile& log, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    if (const Topic* t = log.FindTopic(n, 0)) return t;
  }
  return nullptr;
}

void NormalizeQuat(AttitudeSample* a) {
  const double n = std::sqrt(a->qw * a->qw + a->qx * a->qx + a->qy * a->qy + a->qz * a->qz);
  a->qw /= n;
  a->qx /= n;
  a->qy /= n;
  a->qz /= n;
}

/// Median boot->UTC offset (us) over the GPS records with a plausible UTC time;
/// nullopt when the log has none. The median shrugs off a few glitched records.
std::optional<int64_t> BootToUtcOffsetUs(const Topic* gps, FlightTrack* track) {
  if (!gps) return std::nullopt;
  const auto iu = Field(*gps, {"time_utc_usec"});
  if (!iu) return std::nullopt;
  std::vector<int64_t> offsets;
  for (size_t r = 0; r < gps->size(); ++r) {
    const int64_t utc = static_cast<int64_t>(gps->UInt64Value(r, *iu));
    const int64_t boot = static_cast<int64_t>(gps->TimestampUs(r));
    if (utc >= kMinUtcUs && static_cast<uint64_t>(utc) < kMaxUs && boot > 0 && static_cast<uint64_t>(boot) < kMaxUs) {
      offsets.push_back(utc - boot);
    }
  }
  if (offsets.empty()) return std::nullopt;
  std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
  track->notes.push_back(
      fmt::format("UTC from {}.time_utc_usec (median boot->UTC offset over {} records)", gps->name, offsets.size()));
  return offsets[offsets.size() / 2];
}

/// Boot microseconds to the track's t_ns, counting the implausible timestamps it refuses.
struct BootClock {
  std::optional<int64_t> boot_to_utc_us;
  int bad_times = 0;

  std::optional<int64_t> ToNs(uint64_t boot_us) {
    if (boot_us >= kMaxUs) {
      ++bad_times;
      return std::nullopt;
    }
    return (static_cast<int64_t>(boot_us) + boot_to_utc_us.value_or(0)) * 1000;
  }
};

/// GNSS fixes from the GPS topic, else from the estimator's global position;
/// records without a fix (type < 2, 0,0 or out of range) are dropped and counted.
void AddFixes(const ulog::UlogFile& log, const Topic* gps, BootClock* clock, FlightTrack* track) {
  const Topic* pos = gps;
  if (!pos) {
    pos = log.FindTopic("vehicle_global_position", 0);
    if (pos) track->notes.push_back("no GPS topic: fixes are the estimator's vehicle_global_position");
  }
  if (!pos) return;
  const auto ilat = Field(*pos, {"lat", "latitude_deg"});
  const auto ilon = Field(*pos, {"lon", "longitude_deg"});
  const auto ialt = Field(*pos, {"alt", "altitude_msl_m"});
  const auto ifix = Field(*pos, {"fix_type"});
  const auto isat = Field(*pos, {"satellites_used"});
  const auto ieph = Field(*pos, {"eph"});
  const auto iepv = Field(*pos, {"epv"});
  const auto ivel = Field(*pos, {"vel_m_s"});
  if (!ilat || !ilon) {
    track->notes.push_back(fmt::format("topic {} has no lat/lon fields: no fixes", pos->name));
    return;
  }
  int dropped = 0;
  for (size_t r = 0; r < pos->size(); ++r) {
    GnssFix f;
    const auto t = clock->ToNs(pos->TimestampUs(r));
    if (!t) continue;
    f.t_ns = *t;
    f.lat_deg = Degrees(*pos, r, *ilat);
    f.lon_deg = Degrees(*pos, r, *ilon);
    if (ifix) f.fix_type = static_cast<int>(pos->IntValue(r, *ifix));
    const bool no_fix = (ifix && f.fix_type < 2) || !std::isfinite(f.lat_deg) || !std::isfinite(f.lon_deg) ||
                        std::fabs(f.lat_deg) > 90 || std::fabs(f.lon_deg) > 180 || (f.lat_deg == 0 && f.lon_deg == 0);
    if (no_fix) {
      ++dropped;
      continue;
    }
    if (ialt) {
      f.alt_m = Metres(*pos, r, *ialt);
      f.alt_ref = AltitudeReference::kAmsl;
    }
    if (isat) f.satellites = static_cast<int>(pos->IntValue(r, *isat));
    if (ieph) f.h_acc_m = pos->Value(r, *ieph);
    if (iepv) f.v_acc_m = pos->Value(r, *iepv);
    if (ivel) f.ground_speed_m_s = pos->Value(r, *ivel);
    track->fixes.push_back(f);
  }
  if (dropped > 0) {
    track->notes.push_back(
        fmt::format("dropped {} of {} {} records without a position fix", dropped, pos->size(), pos->name));
  }
}

/// Attitude from vehicle_attitude's quaternion (or older PX4's Euler angles);
/// quaternions far from unit norm are dropped and counted.
void AddAttitude(const ulog::UlogFile& log, BootClock* clock, FlightTrack* track) {
  const Topic* att = log.FindTopic("vehicle_attitude", 0);
  if (!att) return;
  const auto q0 = Field(*att, {"q[0]"});
  const auto roll = Field(*att, {"roll"}), pitch = Field(*att, {"pitch"}), yaw = Field(*att, {"yaw"});
  int dropped = 0;
  for (size_t r = 0; r < att->size(); ++r) {
    AttitudeSample a;
    const auto t = clock->ToNs(att->TimestampUs(r));
    if (!t) continue;
    a.t_ns = *t;
    if (q0) {
      a.qw = att->Value(r, *q0);
      a.qx = att->Value(r, *q0 + 1);
      a.qy = att->Value(r, *q0 + 2);
      a.qz = att->Value(r, *q0 + 3);
    } else if (roll && pitch && yaw) {
      // Older PX4: Euler angles (rad), ZYX order: q = Rz(yaw) Ry(pitch) Rx(roll).
      const double cr = std::cos(att->Value(r, *roll) / 2), sr = std::sin(att->Value(r, *roll) / 2);
      const double cp = std::cos(att->Value(r, *pitch) / 2), sp = std::sin(att->Value(r, *pitch) / 2);
      const double cy = std::cos(att->Value(r, *yaw) / 2), sy = std::sin(att->Value(r, *yaw) / 2);
      a.qw = cr * cp * cy + sr * sp * sy;
      a.qx = sr * cp * cy - cr * sp * sy;
      a.qy = cr * sp * cy + sr * cp * sy;
      a.qz = cr * cp * sy - sr * sp * cy;
    } else {
      break;
    }
    const double n2 = a.qw * a.qw + a.qx * a.qx + a.qy * a.qy + a.qz * a.qz;
    if (!std::isfinite(n2) || n2 < 0.5 || n2 > 1.5) {
      ++dropped;  // PX4 logs zeros before the estimator has converged
      continue;
    }
    NormalizeQuat(&a);
    track->attitude.push_back(a);
  }
  if (dropped > 0)
    track->notes.push_back(fmt::format("dropped {} vehicle_attitude records with an invalid quaternion", dropped));
}

/// Camera capture (or trigger) events, with the position PX4 logged for each where it did.
void AddCameraEvents(const ulog::UlogFile& log, BootClock* clock, FlightTrack* track) {
  const Topic* cam = FirstTopic(log, {"camera_capture", "camera_trigger"});
  if (!cam) return;
  const auto iseq = Field(*cam, {"seq"});
  const auto ilat = Field(*cam, {"lat"}), ilon = Field(*cam, {"lon"}), ialt = Field(*cam, {"alt"});
  for (size_t r = 0; r < cam->size(); ++r) {
    CameraEvent e;
    const auto t = clock->ToNs(cam->TimestampUs(r));
    if (!t) continue;
    e.t_ns = *t;
    if (iseq) e.sequence = cam->IntValue(r, *iseq);
    if (ilat && ilon) {
      e.lat_deg = Degrees(*cam, r, *ilat);
      e.lon_deg = Degrees(*cam, r, *ilon);
    }
    if (ialt) {
      e.alt_m = Metres(*cam, r, *ialt);
      e.alt_ref = AltitudeReference::kAmsl;
    }
    track->camera_events.push_back(e);
  }
  track->notes.push_back(fmt::format("camera events from {}", cam->name));
}

/// Notes on what the file reader skipped, so a damaged log says so.
void AddFileNotes(const ulog::UlogFile& log, FlightTrack* track) {
  for (const ulog::Skip& s : log.skips) {
    track->notes.push_back(fmt::format("skipped {} bytes at byte {}: {}", s.bytes, s.offset, s.reason));
  }
  if (log.messages_cut_at_appended_offset > 0) {
    track->notes.push_back(
        fmt::format("{} message(s) cut where appended data starts", log.messages_cut_at_appended_offset));
  }
  if (log.cut) {
    const ulog::CutShort& c = *log.cut;
    track->notes.push_back(fmt::format(
        "log cut short (power loss?): read {} of {} bytes, {} complete messages, logged boot time {:.3f} to {:.3f} "
        "s; the message at byte {} is incomplete ({}){}",
        c.offset, c.file_bytes, c.messages_read, log.start_timestamp_us * 1e-6, log.last_timestamp_us * 1e-6, c.offset,
        c.reason, log.appended_offsets_past_end > 0 ? "; the appended data it announces was lost" : ""));
  }
  for (const auto& [type, n] : log.unknown_message_types) {
    track->notes.push_back(fmt::format("skipped {} message(s) of unknown type '{}'", n, type));
  }
}

}  // namespace

FlightTrack UlogToFlightTrack(const ulog::UlogFile& log, const std::string& path) {
  FlightTrack track;
  track.source_path = path;
  track.format = "px4-ulog";

  // Time: offset from boot microseconds to UTC microseconds, from the GPS topic.
  const Topic* gps = FirstTopic(log, {"vehicle_gps_position", "sensor_gps"});
  BootClock clock;
  clock.boot_to_utc_us = BootToUtcOffsetUs(gps, &track);
  track.time_base = clock.boot_to_utc_us ? TimeBase::kUtc : TimeBase::kBoot;
  if (!clock.boot_to_utc_us) {
    track.notes.push_back("no GPS UTC time in the log: t_ns is time since autopilot boot");
  }

  AddFixes(log, gps, &clock, &track);
  AddAttitude(log, &clock, &track);
  AddCameraEvents(log, &clock, &track);

  if (clock.bad_times > 0)
    track.notes.push_back(fmt::format("dropped {} records with an implausible timestamp", clock.bad_times));
  auto by_t = [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; };
  std::stable_sort(track.fixes.begin(), track.fixes.end(), by_t);
  std::stable_sort(track.attitude.begin(), track.attitude.end(), by_t);
  std::stable_sort(track.camera_events.begin(), track.camera_events.end(), by_t);

  AddFileNotes(log, &track);
  return track;
}

FlightTrack ReadUlogTrack(std::istream& in, const std::string& path, const ulog::ReadOptions& options) {
  return UlogToFlightTrack(ulog::ReadUlogFile(in, path, options), path);
}

FlightTrack ReadUlogTrack(const std::filesystem::path& path, const ulog::ReadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path.string()), "cannot open file");
  return ReadUlogTrack(in, path.string(), options);
}

}  // namespace rs
