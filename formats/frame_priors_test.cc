#include "formats/frame_priors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "formats/input_error.h"

namespace rs {
namespace {

TEST(FramePriors, Nominal) {
  FramePrior a;
  a.id = FrameId{3};
  a.t_ns = 1'700'000'000'123'456'789;
  a.t_log_ns = a.t_ns - 250'000'000;
  a.status = PriorStatus::kOk;
  a.lat_deg = 48.1234567891;
  a.lon_deg = 11.9876543219;
  a.alt_m = 521.25;
  a.alt_ref = AltitudeReference::kAmsl;
  a.has_attitude = true;
  a.qw = 0.5, a.qx = 0.5, a.qy = -0.5, a.qz = 0.5;
  FramePrior b;
  b.id = FrameId{4};
  b.status = PriorStatus::kOutsideSpan;
  std::stringstream ss;
  WriteFramePriors(ss, {a, b});
  const auto back = ReadFramePriors(ss, "frame_priors.csv");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].t_ns, a.t_ns);
  EXPECT_EQ(back[0].t_log_ns, a.t_log_ns);
  EXPECT_NEAR(back[0].lat_deg, a.lat_deg, 1e-10);  // 1e-10 deg ~ 0.01 mm
  EXPECT_NEAR(back[0].lon_deg, a.lon_deg, 1e-10);
  EXPECT_DOUBLE_EQ(back[0].alt_m, 521.25);
  EXPECT_EQ(back[0].alt_ref, AltitudeReference::kAmsl);
  EXPECT_TRUE(back[0].has_attitude);
  EXPECT_DOUBLE_EQ(back[0].qy, -0.5);
  EXPECT_EQ(back[1].status, PriorStatus::kOutsideSpan);
  EXPECT_TRUE(std::isnan(back[1].lat_deg)) << "no value is invented for frames outside the log";
}

TEST(FramePriors, BadStatusNamesLine) {
  std::stringstream ss(
      "frame_id,t_ns,t_log_ns,status,lat_deg,lon_deg,alt_m,alt_ref,h_acc_m,has_attitude,qw,qx,qy,qz\n"
      "0,1,1,maybe,,,,unknown,,0,1,0,0,0\n");
  try {
    ReadFramePriors(ss, "p.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
  }
}

}  // namespace
}  // namespace rs
