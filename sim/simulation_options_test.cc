#include "sim/simulation_options.h"

#include <gtest/gtest.h>

namespace rs {
namespace {

TEST(SimulationOptions, Nominal) {
  for (const auto& name : PresetNames()) {
    const SimulationOptions o = PresetOptions(name);
    EXPECT_EQ(o.preset, name);
    EXPECT_NO_THROW(o.Check()) << name;
  }
  const SimulationOptions demo = PresetOptions("demo");
  EXPECT_GE(demo.num_frames, 40);
  EXPECT_LE(demo.num_frames, 60);
  EXPECT_TRUE(PresetOptions("loop").out_and_back);
  EXPECT_LT(PresetOptions("rtk").gnss_noise_m, 0.05);
  EXPECT_EQ(PresetOptions("car").platform, "car");
}

TEST(SimulationOptions, UnknownPreset) {
  try {
    PresetOptions("moon");
    FAIL() << "expected OptionError";
  } catch (const OptionError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("moon"), std::string::npos);
    for (const auto& name : PresetNames()) EXPECT_NE(msg.find(name), std::string::npos) << msg;
  }
}

TEST(SimulationOptions, FlightBeyondRoad) {
  SimulationOptions o;
  o.num_frames = 1000;
  try {
    o.Check();
    FAIL() << "expected OptionError";
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("simulate.num_frames = 1000 violates"), std::string::npos) << e.what();
  }
}

TEST(SimulationOptions, OutOfRange) {
  SimulationOptions o;
  o.damage_resolution_m = 0.01;  // coarser than the 5 mm the truth needs
  EXPECT_THROW(o.Check(), OptionError);
  o = SimulationOptions{};
  o.platform = "boat";
  EXPECT_THROW(o.Check(), OptionError);
}

}  // namespace
}  // namespace rs
