#include "formats/flight_log/dataflash/dataflash_writer.h"

#include "formats/byte_writer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "formats/flight_log/dataflash/gps_time.h"

namespace rs {
namespace dataflash {

GpsWeekMs UtcNsToGpsWeekMs(int64_t utc_ns) {
  const int64_t utc_ms = utc_ns >= 0 ? (utc_ns + 500'000) / 1'000'000 : -((-utc_ns + 499'999) / 1'000'000);
  const int64_t base_ms = utc_ms - kGpsEpochUnixS * 1000;  // GPS time without leap seconds
  if (base_ms < 0) throw std::invalid_argument(fmt::format("UTC time {} ns is before the GPS epoch", utc_ns));
  // The leap count is a function of GPS time, which itself includes it: a second look settles it.
  const int64_t leap_s = GpsUtcLeapSeconds(base_ms / 1000 + GpsUtcLeapSeconds(base_ms / 1000));
  const int64_t gps_ms = base_ms + leap_s * 1000;
  return {gps_ms / 604'800'000LL, gps_ms % 604'800'000LL};
}

}  // namespace dataflash

namespace {

constexpr uint8_t kHead1 = 0xA3, kHead2 = 0x95, kFmtType = 128;
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

int64_t RoundUs(int64_t t_ns) { return t_ns >= 0 ? (t_ns + 500) / 1000 : -((-t_ns + 499) / 1000); }

template <typename T>
T Checked(double v, const char* what) {
  const double r = std::round(v);
  if (!std::isfinite(r) || r < static_cast<double>(std::numeric_limits<T>::min()) ||
      r > static_cast<double>(std::numeric_limits<T>::max())) {
    throw std::invalid_argument(fmt::format("DataFlash writer: {} = {} out of range", what, v));
  }
  return static_cast<T>(r);
}

double AmslM(double alt_m, AltitudeReference ref, double geoid_height_m, const char* what) {
  if (!std::isfinite(alt_m) || ref == AltitudeReference::kAmsl) return alt_m;
  if (ref == AltitudeReference::kEllipsoid && std::isfinite(geoid_height_m)) return alt_m - geoid_height_m;
  throw std::invalid_argument(
      fmt::format("DataFlash writer: {} altitude is {}, but DataFlash stores AMSL altitudes{}", what, ToString(ref),
                  ref == AltitudeReference::kEllipsoid ? " (set DataflashWriteOptions::geoid_height_m)" : ""));
}

/// Roll, pitch, yaw in centidegrees (ZYX Euler angles of body FRD in NED),
/// yaw wrapped to 0..35999 as ArduPilot logs it.
struct EulerCd {
  int16_t roll, pitch;
  uint16_t yaw;
};
EulerCd ToEulerCd(const AttitudeSample& a) {
  const double n = std::sqrt(a.qw * a.qw + a.qx * a.qx + a.qy * a.qy + a.qz * a.qz);
  if (!std::isfinite(n) || n < 1e-9)
    throw std::invalid_argument(fmt::format("DataFlash writer: invalid attitude quaternion at {} ns", a.t_ns));
  const double w = a.qw / n, x = a.qx / n, y = a.qy / n, z = a.qz / n;
  const double roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  const double pitch = std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
  const double yaw = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  int64_t yaw_cd = std::llround(yaw * kRadToDeg * 100) % 36000;
  if (yaw_cd < 0) yaw_cd += 36000;
  return {static_cast<int16_t>(std::llround(roll * kRadToDeg * 100)),
          static_cast<int16_t>(std::llround(pitch * kRadToDeg * 100)), static_cast<uint16_t>(yaw_cd)};
}

/// One message type: its FMT and its encoded records.
class Message {
 public:
  Message(uint8_t type, std::string name) : type_(type), name_(std::move(name)) {}
  /// Declares a column (format character + label).
  void Column(char format, const std::string& label) {
    format_ += format;
    labels_ += (labels_.empty() ? "" : ",") + label;
  }
  template <typename T>
  Message& Put(T v) {
    row_.Put(v);
    return *this;
  }
  /// Ends the record being built; `boot_us` orders it among all messages.
  void EndRow(int64_t boot_us, std::vector<std::pair<int64_t, std::string>>* rows) {
    std::string m;
    m += static_cast<char>(kHead1);
    m += static_cast<char>(kHead2);
    m += static_cast<char>(type_);
    m += row_.str();
    if (m.size() != Length()) throw std::logic_error("DataFlash writer: record length differs from its FMT");
    rows->emplace_back(boot_us, std::move(m));
    row_.clear();
  }
  /// Message length (header included) implied by the columns.
  size_t Length() const {
    static const std::map<char, int> kSize = {{'B', 1}, {'b', 1}, {'h', 2}, {'H', 2}, {'c', 2},  {'C', 2},
                                              {'i', 4}, {'I', 4}, {'e', 4}, {'E', 4}, {'L', 4},  {'f', 4},
                                              {'Q', 8}, {'q', 8}, {'d', 8}, {'n', 4}, {'N', 16}, {'Z', 64}};
    size_t len = 3;
    for (char c : format_) len += static_cast<size_t>(kSize.at(c));
    return len;
  }
  /// The FMT record describing this type.
  std::string Fmt() const { return FmtRecord(type_, Length(), name_, format_, labels_); }
  static std::string FmtRecord(uint8_t type, size_t length, const std::string& name, const std::string& format,
                               const std::string& labels) {
    if (length > 255 || name.size() > 4 || format.size() > 16 || labels.size() > 64) {
      throw std::logic_error("DataFlash writer: FMT field too long");
    }
    std::string m;
    m += static_cast<char>(kHead1);
    m += static_cast<char>(kHead2);
    m += static_cast<char>(kFmtType);
    m += static_cast<char>(type);
    m += static_cast<char>(length);
    return m + LittleEndianBytes().Text(name, 4).Text(format, 16).Text(labels, 64).str();
  }

 private:
  uint8_t type_;
  std::string name_, format_, labels_;
  LittleEndianBytes row_;  // the record being built
};

}  // namespace

void WriteDataflashTrack(std::ostream& out, const FlightTrack& track, const DataflashWriteOptions& options) {
  const bool utc = track.time_base == TimeBase::kUtc;
  const double geoid = options.geoid_height_m;

  int64_t first_us = std::numeric_limits<int64_t>::max();
  for (const auto& f : track.fixes) first_us = std::min(first_us, RoundUs(f.t_ns));
  for (const auto& a : track.attitude) first_us = std::min(first_us, RoundUs(a.t_ns));
  for (const auto& e : track.camera_events) first_us = std::min(first_us, RoundUs(e.t_ns));
  if (first_us == std::numeric_limits<int64_t>::max()) first_us = 0;
  if (utc && options.first_sample_boot_us <= 0)
    throw std::invalid_argument("DataFlash writer: first_sample_boot_us must be > 0");
  const int64_t boot_to_utc_us = utc ? first_us - options.first_sample_boot_us : 0;
  auto boot_us = [&](int64_t t_ns) {
    const int64_t b = RoundUs(t_ns) - boot_to_utc_us;
    if (b < 0)
      throw std::invalid_argument(fmt::format("DataFlash writer: boot-time track has a negative time {} ns", t_ns));
    return b;
  };
  auto gps_time = [&](int64_t t_ns) { return utc ? dataflash::UtcNsToGpsWeekMs(t_ns) : dataflash::GpsWeekMs{}; };

  const auto& fixes = track.fixes;
  const auto& events = track.camera_events;
  const bool all_status =
      std::all_of(fixes.begin(), fixes.end(), [](const GnssFix& f) { return f.fix_type >= 0 && f.fix_type <= 255; });
  const bool all_sats = std::all_of(fixes.begin(), fixes.end(),
                                    [](const GnssFix& f) { return f.satellites >= 0 && f.satellites <= 255; });
  const bool all_img = std::all_of(events.begin(), events.end(), [](const CameraEvent& e) {
    return e.sequence >= 0 && e.sequence <= std::numeric_limits<uint32_t>::max();
  });
  const bool all_pos = std::all_of(events.begin(), events.end(), [](const CameraEvent& e) {
    return std::isfinite(e.lat_deg) && std::isfinite(e.lon_deg);
  });
  const bool all_alt =
      std::all_of(events.begin(), events.end(), [](const CameraEvent& e) { return std::isfinite(e.alt_m); });
  const bool all_att = std::all_of(events.begin(), events.end(), [&](const CameraEvent& e) {
    return AttitudeAt(track.attitude, e.t_ns).has_value();
  });

  std::vector<std::pair<int64_t, std::string>> rows;

  Message gps(130, "GPS");
  for (auto [c, l] : {std::pair{'Q', "TimeUS"}, {'B', "I"}}) gps.Column(c, l);
  if (all_status) gps.Column('B', "Status");
  gps.Column('I', "GMS");
  gps.Column('H', "GWk");
  if (all_sats) gps.Column('B', "NSats");
  for (auto [c, l] : {std::pair{'L', "Lat"}, {'L', "Lng"}, {'e', "Alt"}, {'f', "Spd"}}) gps.Column(c, l);
  for (const GnssFix& f : fixes) {
    if (!std::isfinite(f.lat_deg) || !std::isfinite(f.lon_deg) || std::fabs(f.lat_deg) > 90 ||
        std::fabs(f.lon_deg) > 180) {
      throw std::invalid_argument(fmt::format("DataFlash writer: fix at {} ns has no valid lat/lon", f.t_ns));
    }
    const dataflash::GpsWeekMs g = gps_time(f.t_ns);
    gps.Put<uint64_t>(static_cast<uint64_t>(boot_us(f.t_ns))).Put<uint8_t>(0);
    if (all_status) gps.Put(static_cast<uint8_t>(f.fix_type));
    gps.Put(static_cast<uint32_t>(g.ms)).Put(static_cast<uint16_t>(g.week));
    if (all_sats) gps.Put(static_cast<uint8_t>(f.satellites));
    gps.Put(Checked<int32_t>(f.lat_deg * 1e7, "lat")).Put(Checked<int32_t>(f.lon_deg * 1e7, "lon"));
    gps.Put(Checked<int32_t>(AmslM(f.alt_m, f.alt_ref, geoid, "fix") * 100, "fix altitude (AMSL, cm)"));
    gps.Put(static_cast<float>(f.ground_speed_m_s));
    gps.EndRow(boot_us(f.t_ns), &rows);
  }

  Message att(131, "ATT");
  for (auto [c, l] : {std::pair{'Q', "TimeUS"}, {'c', "Roll"}, {'c', "Pitch"}, {'C', "Yaw"}}) att.Column(c, l);
  for (const AttitudeSample& a : track.attitude) {
    const EulerCd e = ToEulerCd(a);
    att.Put<uint64_t>(static_cast<uint64_t>(boot_us(a.t_ns))).Put(e.roll).Put(e.pitch).Put(e.yaw);
    att.EndRow(boot_us(a.t_ns), &rows);
  }

  Message cam(132, "CAM");
  for (auto [c, l] : {std::pair{'Q', "TimeUS"}, {'B', "I"}}) cam.Column(c, l);
  if (all_img) cam.Column('I', "Img");
  cam.Column('I', "GPSTime");
  cam.Column('H', "GPSWeek");
  if (all_pos) cam.Column('L', "Lat"), cam.Column('L', "Lng");
  if (all_alt) cam.Column('e', "Alt"), cam.Column('e', "GPSAlt");
  if (all_att) cam.Column('c', "R"), cam.Column('c', "P"), cam.Column('C', "Y");
  for (const CameraEvent& e : events) {
    const dataflash::GpsWeekMs g = gps_time(e.t_ns);
    cam.Put<uint64_t>(static_cast<uint64_t>(boot_us(e.t_ns))).Put<uint8_t>(0);
    if (all_img) cam.Put(static_cast<uint32_t>(e.sequence));
    cam.Put(static_cast<uint32_t>(g.ms)).Put(static_cast<uint16_t>(g.week));
    if (all_pos)
      cam.Put(Checked<int32_t>(e.lat_deg * 1e7, "camera lat")).Put(Checked<int32_t>(e.lon_deg * 1e7, "camera lon"));
    if (all_alt) {
      const int32_t alt_cm =
          Checked<int32_t>(AmslM(e.alt_m, e.alt_ref, geoid, "camera event") * 100, "camera altitude (cm)");
      cam.Put(alt_cm).Put(alt_cm);
    }
    if (all_att) {
      const EulerCd r = ToEulerCd(*AttitudeAt(track.attitude, e.t_ns));  // all_att: every event has one
      cam.Put(r.roll).Put(r.pitch).Put(r.yaw);
    }
    cam.EndRow(boot_us(e.t_ns), &rows);
  }

  std::stable_sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::string s = Message::FmtRecord(kFmtType, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns");
  for (const Message* m : {&gps, &att, &cam}) s += m->Fmt();
  for (const auto& r : rows) s += r.second;
  out.write(s.data(), static_cast<std::streamsize>(s.size()));
}

void WriteDataflashTrack(const std::filesystem::path& path, const FlightTrack& track,
                         const DataflashWriteOptions& options) {
  WriteBinaryFile(path, [&](std::ostream& out) { WriteDataflashTrack(out, track, options); });
}

}  // namespace rs
