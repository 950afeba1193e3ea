#include "stages/ingest/time_alignment.h"

#include "survey/stats/order_statistic.h"

#include <Eigen/Geometry>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace rs {
namespace {

constexpr int kMaxMessagesPerKind = 5;
constexpr double kEarthRadiusM = 6371008.8;

int64_t Median(std::vector<int64_t> v) { return LowerMedianInPlace(v); }

double HaversineM(double lat1, double lon1, double lat2, double lon2) {
  const double d2r = M_PI / 180.0;
  const double dlat = (lat2 - lat1) * d2r, dlon = (lon2 - lon1) * d2r;
  const double a = std::sin(dlat / 2) * std::sin(dlat / 2) +
                   std::cos(lat1 * d2r) * std::cos(lat2 * d2r) * std::sin(dlon / 2) * std::sin(dlon / 2);
  return 2 * kEarthRadiusM * std::asin(std::min(1.0, std::sqrt(a)));
}

double Lerp(double a, double b, double w) { return a + (b - a) * w; }

}  // namespace

std::optional<ClockOffsetEstimate> EstimateClockOffsetFromEvents(const std::vector<int64_t>& frame_t_ns,
                                                                 const std::vector<CameraEvent>& events,
                                                                 int64_t prior_offset_ns, int min_pairs,
                                                                 int64_t confident_spread_ns) {
  const int nf = static_cast<int>(frame_t_ns.size()), ne = static_cast<int>(events.size());
  if (ne < min_pairs || nf < min_pairs) return std::nullopt;
  // Require the pairing to cover at least half of the shorter sequence, so a
  // shift that overlaps only a few samples cannot win by chance.
  const int min_overlap = std::max(min_pairs, std::min(nf, ne) / 2);
  std::vector<ClockOffsetEstimate> candidates;
  for (int shift = -(nf - 1); shift <= ne - 1; ++shift) {
    std::vector<int64_t> d;
    for (int i = std::max(0, -shift); i < nf && i + shift < ne; ++i)
      d.push_back(frame_t_ns[i] - events[i + shift].t_ns);
    if (static_cast<int>(d.size()) < min_overlap) continue;
    const int64_t med = Median(d);
    std::vector<int64_t> dev(d.size());
    for (size_t k = 0; k < d.size(); ++k) dev[k] = std::llabs(d[k] - med);
    candidates.push_back({med, Median(dev), static_cast<int>(d.size()), shift, false, "camera-events"});
  }
  if (candidates.empty()) return std::nullopt;
  std::vector<ClockOffsetEstimate> consistent;
  for (const auto& c : candidates)
    if (c.spread_ns <= confident_spread_ns) consistent.push_back(c);
  if (consistent.empty()) {
    // Nothing agrees: report the least inconsistent pairing, not confident.
    return *std::min_element(candidates.begin(), candidates.end(),
                             [](const auto& a, const auto& b) { return a.spread_ns < b.spread_ns; });
  }
  const int most = std::max_element(consistent.begin(), consistent.end(), [](const auto& a, const auto& b) {
                     return a.matched_pairs < b.matched_pairs;
                   })->matched_pairs;
  std::vector<ClockOffsetEstimate> best;
  for (const auto& c : consistent)
    if (c.matched_pairs == most) best.push_back(c);
  auto distance = [&](const ClockOffsetEstimate& c) { return std::llabs(c.offset_ns - prior_offset_ns); };
  std::sort(best.begin(), best.end(), [&](const auto& a, const auto& b) { return distance(a) < distance(b); });
  ClockOffsetEstimate chosen = best.front();
  // Unique, or the prior lies clearly closer to it than to the runner-up.
  chosen.confident = best.size() == 1 || 2 * distance(best[0]) < distance(best[1]);
  return chosen;
}

std::vector<FramePrior> InterpolatePriors(const std::vector<FrameRecord>& frames, const FlightTrack& track,
                                          int64_t clock_offset_ns, int64_t max_gap_ns) {
  std::vector<FramePrior> priors;
  priors.reserve(frames.size());
  const auto& fixes = track.fixes;
  const auto& att = track.attitude;
  for (const auto& f : frames) {
    FramePrior p;
    p.id = f.id;
    p.t_ns = f.t_ns;
    p.t_log_ns = f.t_ns - clock_offset_ns;
    if (fixes.empty()) {
      priors.push_back(p);
      continue;
    }
    const auto hi = std::lower_bound(fixes.begin(), fixes.end(), p.t_log_ns,
                                     [](const GnssFix& g, int64_t t) { return g.t_ns < t; });
    if (hi == fixes.end() || (hi == fixes.begin() && hi->t_ns != p.t_log_ns)) {
      p.status = PriorStatus::kOutsideSpan;
    } else {
      const GnssFix& b = *hi;
      const GnssFix& a = hi == fixes.begin() ? b : *(hi - 1);
      if (b.t_ns - a.t_ns > max_gap_ns) {
        p.status = PriorStatus::kInGap;
      } else {
        const double w = b.t_ns == a.t_ns ? 0.0 : double(p.t_log_ns - a.t_ns) / double(b.t_ns - a.t_ns);
        p.status = PriorStatus::kOk;
        p.lat_deg = Lerp(a.lat_deg, b.lat_deg, w);
        p.lon_deg = Lerp(a.lon_deg, b.lon_deg, w);
        p.alt_m = Lerp(a.alt_m, b.alt_m, w);
        p.alt_ref = a.alt_ref;
        p.h_acc_m = Lerp(a.h_acc_m, b.h_acc_m, w);
      }
    }
    const auto ahi = std::lower_bound(att.begin(), att.end(), p.t_log_ns,
                                      [](const AttitudeSample& s, int64_t t) { return s.t_ns < t; });
    if (ahi != att.end() && (ahi != att.begin() || ahi->t_ns == p.t_log_ns)) {
      const AttitudeSample& b = *ahi;
      const AttitudeSample& a = ahi == att.begin() ? b : *(ahi - 1);
      if (b.t_ns - a.t_ns <= max_gap_ns) {
        const double w = b.t_ns == a.t_ns ? 0.0 : double(p.t_log_ns - a.t_ns) / double(b.t_ns - a.t_ns);
        const Eigen::Quaterniond qa(a.qw, a.qx, a.qy, a.qz), qb(b.qw, b.qx, b.qy, b.qz);
        const Eigen::Quaterniond q = qa.normalized().slerp(w, qb.normalized());
        p.has_attitude = true;
        p.qw = q.w(), p.qx = q.x(), p.qy = q.y(), p.qz = q.z();
      }
    }
    priors.push_back(p);
  }
  return priors;
}

TrackFindings CheckTrack(const FlightTrack& track, int64_t max_gap_ns, double max_speed_m_s) {
  TrackFindings out;
  const auto& fixes = track.fixes;
  int gap_msgs = 0, jump_msgs = 0;
  for (size_t i = 0; i < fixes.size(); ++i) {
    if (fixes[i].fix_type == 0 || fixes[i].fix_type == 1) ++out.no_fix;
    if (i == 0) continue;
    const int64_t dt = fixes[i].t_ns - fixes[i - 1].t_ns;
    if (dt > max_gap_ns) {
      ++out.gaps;
      if (gap_msgs++ < kMaxMessagesPerKind)
        out.messages.push_back(
            fmt::format("log gap of {:.2f} s after fix {} (t = {} ns)", dt * 1e-9, i - 1, fixes[i - 1].t_ns));
    }
    if (dt > 0) {
      const double speed =
          HaversineM(fixes[i - 1].lat_deg, fixes[i - 1].lon_deg, fixes[i].lat_deg, fixes[i].lon_deg) / (dt * 1e-9);
      if (speed > max_speed_m_s) {
        ++out.jumps;
        if (jump_msgs++ < kMaxMessagesPerKind)
          out.messages.push_back(fmt::format("implausible jump at fix {} (t = {} ns): {:.1f} m/s > {:.1f} m/s", i,
                                             fixes[i].t_ns, speed, max_speed_m_s));
      }
    }
  }
  if (out.no_fix > 0) out.messages.push_back(fmt::format("{} fixes flagged as no fix", out.no_fix));
  return out;
}

}  // namespace rs
