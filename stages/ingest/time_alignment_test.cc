#include "stages/ingest/time_alignment.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

namespace rs {
namespace {

constexpr int64_t kMs = 1'000'000;

TEST(ClockOffset, Nominal) {
  // 100 frames at 10 Hz on the camera clock; the log clock lags by 2.345 s and has
  // trigger jitter of +-1 ms; the log starts 3 events before the first frame.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int64_t> jitter(-kMs, kMs);
  const int64_t offset = 2345 * kMs;
  std::vector<int64_t> frames;
  std::vector<CameraEvent> events;
  for (int i = -3; i < 100; ++i) {
    const int64_t t_cam = 1'000'000 * kMs + i * 100 * kMs;
    if (i >= 0) frames.push_back(t_cam);
    events.push_back({t_cam - offset + jitter(rng), i + 3});
  }
  // The log has 3 extra events, so pairings shifted by 0..3 periods all match 100 frames
  // equally well: a rough configured offset (2.3 s) picks the right one.
  const auto est = EstimateClockOffsetFromEvents(frames, events, 2300 * kMs);
  ASSERT_TRUE(est);
  EXPECT_TRUE(est->confident);
  EXPECT_EQ(est->index_shift, 3);
  EXPECT_NEAR(est->offset_ns, offset, 1 * kMs);  // within the trigger jitter
  EXPECT_EQ(est->matched_pairs, 100);
}

TEST(ClockOffset, AmbiguousPeriodicPairingIsNotConfident) {
  // Same as Nominal (candidates 2345, 2445, 2545, 2645 ms), but the configured offset sits halfway
  // between the two nearest.
  std::vector<int64_t> frames;
  std::vector<CameraEvent> events;
  for (int i = -3; i < 100; ++i) {
    const int64_t t_cam = i * 100 * kMs;
    if (i >= 0) frames.push_back(t_cam);
    events.push_back({t_cam - 2345 * kMs});
  }
  const auto est = EstimateClockOffsetFromEvents(frames, events, 2395 * kMs);
  ASSERT_TRUE(est);
  EXPECT_FALSE(est->confident);
}

TEST(ClockOffset, EqualCountsNeedNoPrior) {
  std::vector<int64_t> frames;
  std::vector<CameraEvent> events;
  for (int i = 0; i < 60; ++i) {
    frames.push_back(i * 50 * kMs);
    events.push_back({i * 50 * kMs + 7777 * kMs});
  }
  const auto est = EstimateClockOffsetFromEvents(frames, events, 0);
  ASSERT_TRUE(est);
  EXPECT_TRUE(est->confident);
  EXPECT_EQ(est->offset_ns, -7777 * kMs);
  EXPECT_EQ(est->matched_pairs, 60);
}

TEST(ClockOffset, TooFewEvents) { EXPECT_FALSE(EstimateClockOffsetFromEvents({1, 2, 3, 4, 5, 6}, {{1}, {2}})); }

TEST(ClockOffset, IrregularEventsAreNotConfident) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int64_t> any(0, 10'000 * kMs);
  std::vector<int64_t> frames;
  std::vector<CameraEvent> events;
  for (int i = 0; i < 50; ++i) frames.push_back(i * 100 * kMs);
  for (int i = 0; i < 50; ++i) events.push_back({any(rng)});
  std::sort(events.begin(), events.end(), [](auto& a, auto& b) { return a.t_ns < b.t_ns; });
  const auto est = EstimateClockOffsetFromEvents(frames, events);
  ASSERT_TRUE(est);
  EXPECT_FALSE(est->confident);
}

FlightTrack LineTrack() {
  // Fixes every 200 ms moving north at 10 m/s-ish; a 5 s gap after t = 2 s.
  FlightTrack t;
  for (int i = 0; i <= 10; ++i) {
    GnssFix f;
    f.t_ns = i * 200 * kMs;
    f.lat_deg = 48.0 + i * 1e-5;
    f.lon_deg = 11.0;
    f.alt_m = 500 + i;
    f.alt_ref = AltitudeReference::kAmsl;
    t.fixes.push_back(f);
  }
  GnssFix late = t.fixes.back();
  late.t_ns += 5000 * kMs;
  late.lat_deg += 1e-5;
  t.fixes.push_back(late);
  const Eigen::Quaterniond qa(Eigen::AngleAxisd(0.0, Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond qb(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  t.attitude.push_back({0, qa.w(), qa.x(), qa.y(), qa.z()});
  t.attitude.push_back({1000 * kMs, qb.w(), qb.x(), qb.y(), qb.z()});
  return t;
}

TEST(InterpolatePriors, Nominal) {
  const FlightTrack track = LineTrack();
  // Camera clock is 1 s ahead of the log.
  std::vector<FrameRecord> frames = {{FrameId{0}, 1100 * kMs, "", ""}};
  const auto priors = InterpolatePriors(frames, track, 1000 * kMs, 2000 * kMs);
  ASSERT_EQ(priors.size(), 1u);
  const auto& p = priors[0];
  EXPECT_EQ(p.status, PriorStatus::kOk);
  EXPECT_EQ(p.t_log_ns, 100 * kMs);
  EXPECT_NEAR(p.lat_deg, 48.0 + 0.5e-5, 1e-12);
  EXPECT_NEAR(p.alt_m, 500.5, 1e-9);
  EXPECT_EQ(p.alt_ref, AltitudeReference::kAmsl);
  ASSERT_TRUE(p.has_attitude);
  // Slerp a tenth of the way from 0 to 90 degrees about z: 9 degrees.
  const Eigen::Quaterniond q(p.qw, p.qx, p.qy, p.qz);
  EXPECT_NEAR(Eigen::AngleAxisd(q).angle(), M_PI / 20, 1e-9);
}

TEST(InterpolatePriors, OutsideSpanAndGapAreFlaggedNotExtrapolated) {
  const FlightTrack track = LineTrack();
  std::vector<FrameRecord> frames = {
      {FrameId{0}, -1 * kMs, "", ""}, {FrameId{1}, 4000 * kMs, "", ""}, {FrameId{2}, 99'000 * kMs, "", ""}};
  const auto priors = InterpolatePriors(frames, track, 0, 2000 * kMs);
  EXPECT_EQ(priors[0].status, PriorStatus::kOutsideSpan);
  EXPECT_EQ(priors[1].status, PriorStatus::kInGap);
  EXPECT_EQ(priors[2].status, PriorStatus::kOutsideSpan);
  for (const auto& p : priors) EXPECT_TRUE(std::isnan(p.lat_deg));
}

TEST(CheckTrack, GapsAndJumps) {
  FlightTrack track = LineTrack();
  track.fixes[5].lon_deg += 0.01;  // ~740 m sideways in 200 ms, and back
  track.fixes[3].fix_type = 0;
  const auto findings = CheckTrack(track, 2000 * kMs, 60.0);
  EXPECT_EQ(findings.gaps, 1);
  EXPECT_EQ(findings.jumps, 2);
  EXPECT_EQ(findings.no_fix, 1);
  EXPECT_FALSE(findings.messages.empty());
}

}  // namespace
}  // namespace rs
