#include "formats/flight_log/ulog/ulog_writer.h"

#include "formats/byte_writer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include <fmt/format.h>

namespace rs {
namespace {

// Message types of the ULog spec.
constexpr char kFlagBits = 'B', kFormat = 'F', kInfo = 'I', kAddLogged = 'A', kData = 'D';

using Bytes = LittleEndianBytes;

void PutMessage(std::string* out, char type, const std::string& payload) {
  if (payload.size() > 0xFFFF) throw std::invalid_argument("ULog message larger than 64 KiB");
  *out += Bytes().Put(static_cast<uint16_t>(payload.size())).str();
  *out += type;
  *out += payload;
}

int64_t RoundUs(int64_t t_ns) {
  // Round half up on the integer grid, also for negative times.
  return t_ns >= 0 ? (t_ns + 500) / 1000 : -((-t_ns + 499) / 1000);
}

int32_t ScaledInt32(double v, double scale, const char* what) {
  const double s = std::round(v * scale);
  if (!std::isfinite(s) || s < std::numeric_limits<int32_t>::min() || s > std::numeric_limits<int32_t>::max()) {
    throw std::invalid_argument(fmt::format("ULog writer: {} = {} cannot be stored as int32", what, v));
  }
  return static_cast<int32_t>(s);
}

// AMSL altitude of a value referenced to `ref` (NaN stays NaN).
double AmslM(double alt_m, AltitudeReference ref, double geoid_height_m, const char* what) {
  if (!std::isfinite(alt_m)) return alt_m;
  if (ref == AltitudeReference::kAmsl) return alt_m;
  if (ref == AltitudeReference::kEllipsoid && std::isfinite(geoid_height_m)) return alt_m - geoid_height_m;
  throw std::invalid_argument(
      fmt::format("ULog writer: {} altitude is {}, but ULog stores AMSL altitudes{}", what, ToString(ref),
                  ref == AltitudeReference::kEllipsoid ? " (set UlogWriteOptions::geoid_height_m)" : ""));
}

/// A data record waiting to be written, ordered by boot time.
struct Record {
  int64_t boot_us;
  uint16_t msg_id;
  std::string bytes;
};

}  // namespace

void WriteUlogTrack(std::ostream& out, const FlightTrack& track, const UlogWriteOptions& options) {
  const bool utc = track.time_base == TimeBase::kUtc;
  const double geoid = options.geoid_height_m;

  // Boot clock: UTC tracks start at first_sample_boot_us; boot tracks keep their clock.
  int64_t first_us = std::numeric_limits<int64_t>::max();
  for (const auto& f : track.fixes) first_us = std::min(first_us, RoundUs(f.t_ns));
  for (const auto& a : track.attitude) first_us = std::min(first_us, RoundUs(a.t_ns));
  for (const auto& e : track.camera_events) first_us = std::min(first_us, RoundUs(e.t_ns));
  if (first_us == std::numeric_limits<int64_t>::max()) first_us = 0;
  if (utc && options.first_sample_boot_us <= 0) {
    throw std::invalid_argument("ULog writer: first_sample_boot_us must be > 0");
  }
  const int64_t boot_to_utc_us = utc ? first_us - options.first_sample_boot_us : 0;
  auto boot_us = [&](int64_t t_ns) {
    const int64_t b = RoundUs(t_ns) - boot_to_utc_us;
    if (b < 0) throw std::invalid_argument(fmt::format("ULog writer: boot-time track has a negative time {} ns", t_ns));
    return b;
  };

  const bool all_fix_type = std::all_of(track.fixes.begin(), track.fixes.end(),
                                        [](const GnssFix& f) { return f.fix_type >= 0 && f.fix_type <= 255; });
  const bool all_sats = std::all_of(track.fixes.begin(), track.fixes.end(),
                                    [](const GnssFix& f) { return f.satellites >= 0 && f.satellites <= 255; });
  const bool all_seq = std::all_of(track.camera_events.begin(), track.camera_events.end(), [](const CameraEvent& e) {
    return e.sequence >= 0 && e.sequence <= std::numeric_limits<uint32_t>::max();
  });
  const bool with_ellipsoid = std::isfinite(geoid);

  // Field order follows PX4's logged layout: 8-byte fields, then 4-byte, then 1-byte.
  std::string gps_fmt =
      "vehicle_gps_position:uint64_t timestamp;uint64_t time_utc_usec;int32_t lat;int32_t lon;int32_t alt;";
  if (with_ellipsoid) gps_fmt += "int32_t alt_ellipsoid;";
  gps_fmt += "float eph;float epv;float vel_m_s;";
  if (all_fix_type) gps_fmt += "uint8_t fix_type;";
  if (all_sats) gps_fmt += "uint8_t satellites_used;";
  const std::string att_fmt = "vehicle_attitude:uint64_t timestamp;float[4] q;";
  std::string cam_fmt = "camera_capture:uint64_t timestamp;uint64_t timestamp_utc;double lat;double lon;";
  if (all_seq) cam_fmt += "uint32_t seq;";
  cam_fmt += "float alt;float[4] q;int8_t result;";

  constexpr uint16_t kGpsId = 0, kAttId = 1, kCamId = 2;
  std::vector<Record> records;
  records.reserve(track.fixes.size() + track.attitude.size() + track.camera_events.size());
  for (const GnssFix& f : track.fixes) {
    if (!std::isfinite(f.lat_deg) || !std::isfinite(f.lon_deg) || std::fabs(f.lat_deg) > 90 ||
        std::fabs(f.lon_deg) > 180) {
      throw std::invalid_argument(fmt::format("ULog writer: fix at {} ns has no valid lat/lon", f.t_ns));
    }
    const double amsl = AmslM(f.alt_m, f.alt_ref, geoid, "fix");
    Bytes b;
    b.Put<uint64_t>(static_cast<uint64_t>(boot_us(f.t_ns)));
    b.Put<uint64_t>(utc ? static_cast<uint64_t>(RoundUs(f.t_ns)) : 0);
    b.Put(ScaledInt32(f.lat_deg, 1e7, "lat_deg")).Put(ScaledInt32(f.lon_deg, 1e7, "lon_deg"));
    b.Put(ScaledInt32(amsl, 1e3, "fix altitude (AMSL)"));
    if (with_ellipsoid) b.Put(ScaledInt32(amsl + geoid, 1e3, "fix altitude (ellipsoid)"));
    b.Put(static_cast<float>(f.h_acc_m)).Put(static_cast<float>(f.v_acc_m)).Put(static_cast<float>(f.ground_speed_m_s));
    if (all_fix_type) b.Put(static_cast<uint8_t>(f.fix_type));
    if (all_sats) b.Put(static_cast<uint8_t>(f.satellites));
    records.push_back({boot_us(f.t_ns), kGpsId, std::move(b.str())});
  }
  for (const AttitudeSample& a : track.attitude) {
    Bytes b;
    b.Put<uint64_t>(static_cast<uint64_t>(boot_us(a.t_ns)));
    b.Put(static_cast<float>(a.qw))
        .Put(static_cast<float>(a.qx))
        .Put(static_cast<float>(a.qy))
        .Put(static_cast<float>(a.qz));
    records.push_back({boot_us(a.t_ns), kAttId, std::move(b.str())});
  }
  for (const CameraEvent& e : track.camera_events) {
    double q[4] = {kNaN, kNaN, kNaN, kNaN};
    if (const auto a = AttitudeAt(track.attitude, e.t_ns)) q[0] = a->qw, q[1] = a->qx, q[2] = a->qy, q[3] = a->qz;
    Bytes b;
    b.Put<uint64_t>(static_cast<uint64_t>(boot_us(e.t_ns)));
    b.Put<uint64_t>(utc ? static_cast<uint64_t>(RoundUs(e.t_ns)) : 0);
    b.Put(e.lat_deg).Put(e.lon_deg);
    if (all_seq) b.Put(static_cast<uint32_t>(e.sequence));
    b.Put(static_cast<float>(AmslM(e.alt_m, e.alt_ref, geoid, "camera event")));
    for (double v : q) b.Put(static_cast<float>(v));
    b.Put<int8_t>(1);  // every logged event is a capture that happened
    records.push_back({boot_us(e.t_ns), kCamId, std::move(b.str())});
  }
  std::stable_sort(records.begin(), records.end(),
                   [](const Record& x, const Record& y) { return x.boot_us < y.boot_us; });

  std::string s;
  // Header: magic, version 1, logging start (boot µs).
  s.append("ULog\x01\x12\x35", 7);
  s += static_cast<char>(1);
  s += Bytes().Put<uint64_t>(static_cast<uint64_t>(records.empty() ? 0 : records.front().boot_us)).str();
  // Flag bits: no compat/incompat flags, no appended data.
  PutMessage(&s, kFlagBits, std::string(40, '\0'));
  for (const std::string& f : {gps_fmt, att_fmt, cam_fmt}) PutMessage(&s, kFormat, f);
  auto info = [&](const std::string& key, const std::string& value) {
    const std::string type_key = fmt::format("char[{}] {}", value.size(), key);
    PutMessage(&s, kInfo, Bytes().Put(static_cast<uint8_t>(type_key.size())).Str(type_key).Str(value).str());
  };
  info("sys_name", options.sys_name);
  if (!track.source_path.empty()) info("roadsurvey_source", track.source_path);
  const std::pair<uint16_t, const char*> topics[] = {
      {kGpsId, "vehicle_gps_position"}, {kAttId, "vehicle_attitude"}, {kCamId, "camera_capture"}};
  for (const auto& [id, name] : topics) PutMessage(&s, kAddLogged, Bytes().Put<uint8_t>(0).Put(id).Str(name).str());
  for (const Record& r : records) PutMessage(&s, kData, Bytes().Put(r.msg_id).Str(r.bytes).str());
  out.write(s.data(), static_cast<std::streamsize>(s.size()));
}

void WriteUlogTrack(const std::filesystem::path& path, const FlightTrack& track, const UlogWriteOptions& options) {
  WriteBinaryFile(path, [&](std::ostream& out) { WriteUlogTrack(out, track, options); });
}

}  // namespace rs
