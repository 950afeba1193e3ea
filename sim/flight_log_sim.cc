#include "sim/flight_log_sim.h"

#include <cmath>
#include <ctime>
#include <ostream>

#include <fmt/format.h>

#include "sim/sim_random.h"

namespace rs::sim {

int64_t FrameTimeNs(const SimulationOptions& o, int k) {
  return o.start_time_ns + std::llround(k * 1e9 / o.frame_rate_hz);
}

int64_t CameraTimeNs(const SimulationOptions& o, int k) {
  return FrameTimeNs(o, k) + std::llround(o.clock_offset_s * 1e9);
}

FlightTrack SimulateFlightLog(const SimulationOptions& o, const FlightPath& path,
                              const GeographicLib::LocalCartesian& enu) {
  FlightTrack track;
  track.source_path = "flight_log.csv";
  track.format = "csv";
  track.time_base = TimeBase::kUtc;
  track.notes.push_back(fmt::format("simulated by roadsurvey simulate, preset {}, seed {}", o.preset, o.seed));
  Rng rng(HashCombine(static_cast<uint64_t>(o.seed), 23));

  const int64_t t0 = FrameTimeNs(o, 0) - 1'000'000'000;
  const int64_t t1 = FrameTimeNs(o, o.num_frames - 1) + 1'000'000'000;
  auto rel_s = [&](int64_t t_ns) { return static_cast<double>(t_ns - o.start_time_ns) * 1e-9; };

  // GNSS: first-order Gauss-Markov bias per axis (E, N, U) plus white noise.
  const double dt = 1.0 / o.gnss_rate_hz;
  const double phi = std::exp(-dt / o.gnss_bias_tau_s);
  const double axis_scale[3] = {1.0, 1.0, 1.5};
  Eigen::Vector3d bias;
  for (int a = 0; a < 3; ++a) bias[a] = o.gnss_bias_m * axis_scale[a] * rng.Normal();
  std::vector<std::pair<int64_t, Eigen::Vector3d>> biases;
  const int n_fix = static_cast<int>(std::floor(static_cast<double>(t1 - t0) * 1e-9 / dt)) + 1;
  for (int k = 0; k < n_fix; ++k) {
    const int64_t t_ns = t0 + std::llround(k * dt * 1e9);
    if (k > 0) {
      for (int a = 0; a < 3; ++a)
        bias[a] = phi * bias[a] + o.gnss_bias_m * axis_scale[a] * std::sqrt(1 - phi * phi) * rng.Normal();
    }
    biases.emplace_back(t_ns, bias);
    const PlatformState st = path.At(rel_s(t_ns));
    Eigen::Vector3d p = st.T_world_body.translation() + bias;
    for (int a = 0; a < 3; ++a) p[a] += o.gnss_noise_m * axis_scale[a] * rng.Normal();
    GnssFix f;
    f.t_ns = t_ns;
    enu.Reverse(p.x(), p.y(), p.z(), f.lat_deg, f.lon_deg, f.alt_m);
    f.alt_ref = AltitudeReference::kEllipsoid;
    f.fix_type = o.gnss_rtk ? 6 : 3;
    f.satellites = o.gnss_rtk ? 21 : 14;
    f.h_acc_m = std::hypot(o.gnss_noise_m, o.gnss_bias_m);
    f.v_acc_m = 1.5 * f.h_acc_m;
    f.ground_speed_m_s = std::hypot(st.v_world.x(), st.v_world.y());
    track.fixes.push_back(f);
  }

  // Attitude: body FRD -> local NED, with small random rotation noise.
  Eigen::Matrix3d R_ned_enu;
  R_ned_enu << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  const double sig = o.attitude_noise_deg * 3.14159265358979323846 / 180.0;
  const double dta = 1.0 / o.attitude_rate_hz;
  const int n_att = static_cast<int>(std::floor(static_cast<double>(t1 - t0) * 1e-9 / dta)) + 1;
  for (int k = 0; k < n_att; ++k) {
    const int64_t t_ns = t0 + std::llround(k * dta * 1e9);
    const Eigen::Matrix3d R = R_ned_enu * path.At(rel_s(t_ns)).T_world_body.linear();
    const Eigen::Vector3d e(sig * rng.Normal(), sig * rng.Normal(), sig * rng.Normal());
    Eigen::Quaterniond q(R * Eigen::AngleAxisd(e.norm(), e.norm() > 0 ? e.normalized() : Eigen::Vector3d::UnitX()));
    q.normalize();
    if (q.w() < 0) q.coeffs() *= -1;
    track.attitude.push_back({t_ns, q.w(), q.x(), q.y(), q.z()});
  }

  // Camera triggers at the true exposure times; position = truth + current GNSS bias.
  size_t bi = 0;
  for (int k = 0; k < o.num_frames; ++k) {
    CameraEvent ev;
    ev.t_ns = FrameTimeNs(o, k);
    ev.sequence = k;
    while (bi + 1 < biases.size() && biases[bi + 1].first <= ev.t_ns) ++bi;
    const Eigen::Vector3d p = path.At(rel_s(ev.t_ns)).T_world_body.translation() + biases[bi].second;
    enu.Reverse(p.x(), p.y(), p.z(), ev.lat_deg, ev.lon_deg, ev.alt_m);
    ev.alt_ref = AltitudeReference::kEllipsoid;
    track.camera_events.push_back(ev);
  }
  return track;
}

std::string IsoTimeUtc(int64_t t_ns) {
  const int64_t sec = t_ns >= 0 ? t_ns / 1'000'000'000 : (t_ns - 999'999'999) / 1'000'000'000;
  const int64_t ms = (t_ns - sec * 1'000'000'000) / 1'000'000;
  const std::time_t tt = static_cast<std::time_t>(sec);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  return fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.{:03d}Z", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                     tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms));
}

void WriteGpx(std::ostream& out, const FlightTrack& track, const std::string& name) {
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<gpx version=\"1.1\" creator=\"roadsurvey simulate\" xmlns=\"http://www.topografix.com/GPX/1/1\">\n"
         "  <trk>\n    <name>"
      << name << "</name>\n    <trkseg>\n";
  for (const GnssFix& f : track.fixes) {
    out << fmt::format("      <trkpt lat=\"{:.9f}\" lon=\"{:.9f}\"><ele>{:.3f}</ele><time>{}</time></trkpt>\n",
                       f.lat_deg, f.lon_deg, f.alt_m, IsoTimeUtc(f.t_ns));
  }
  out << "    </trkseg>\n  </trk>\n</gpx>\n";
}

}  // namespace rs::sim
