#include "formats/flight_log/flight_track.h"

#include <gtest/gtest.h>

#include <cmath>

namespace rs {
namespace {

TEST(AttitudeAt, Nominal) {
  // 0 and 90 degrees about z, 1 s apart: halfway is 45 degrees (nlerp is exact at the midpoint).
  const double h = std::sqrt(0.5);
  const std::vector<AttitudeSample> att = {{0, 1, 0, 0, 0}, {1'000'000'000, h, 0, 0, h}};
  const auto mid = AttitudeAt(att, 500'000'000);
  ASSERT_TRUE(mid);
  EXPECT_NEAR(2 * std::atan2(mid->qz, mid->qw), M_PI / 4, 1e-12);
  EXPECT_NEAR(mid->qw * mid->qw + mid->qz * mid->qz, 1.0, 1e-12);
  const auto at = AttitudeAt(att, 1'000'000'000);
  ASSERT_TRUE(at);
  EXPECT_DOUBLE_EQ(at->qz, h);
}

TEST(AttitudeAt, OutsideSamplesIsEmpty) {
  const std::vector<AttitudeSample> att = {{10, 1, 0, 0, 0}, {20, 1, 0, 0, 0}};
  EXPECT_FALSE(AttitudeAt(att, 9));
  EXPECT_FALSE(AttitudeAt(att, 21));
  EXPECT_FALSE(AttitudeAt({}, 0));
}

TEST(AttitudeAt, OppositeSignsTakeTheShortWay) {
  // q and -q are one rotation: interpolating between them must not pass through zero.
  const std::vector<AttitudeSample> att = {{0, 1, 0, 0, 0}, {100, -1, 0, 0, 0}};
  const auto q = AttitudeAt(att, 50);
  ASSERT_TRUE(q);
  EXPECT_NEAR(std::abs(q->qw), 1.0, 1e-12);
}

}  // namespace
}  // namespace rs
