#include "stages/slam/slam_regime.h"

#include <algorithm>
#include <vector>

#include <fmt/format.h>

namespace rs {
namespace {

double Percentile(std::vector<float> v, double q) {
  const size_t k = static_cast<size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

RegimeChoice ChooseRegime(const SlamOptions& options, const StereoFeatures& first_frame) {
  RegimeChoice c;
  std::vector<float> depth;
  for (float d : first_frame.depth_m)
    if (d > 0) depth.push_back(d);
  c.stereo_points = static_cast<int>(depth.size());
  if (c.stereo_points >= kRegimeMinStereoPoints) {
    c.depth_p10_m = Percentile(depth, 0.1);
    c.depth_p90_m = Percentile(depth, 0.9);
    c.depth_spread = c.depth_p90_m / c.depth_p10_m;
  }
  const std::string depths = c.stereo_points >= kRegimeMinStereoPoints
                                 ? fmt::format("first frame's stereo depths span {:.1f}-{:.1f} m (x{:.2f})",
                                               c.depth_p10_m, c.depth_p90_m, c.depth_spread)
                                 : fmt::format("first frame has {} stereo points (< {}): too few to judge",
                                               c.stereo_points, kRegimeMinStereoPoints);
  if (options.regime != SlamRegime::kAuto) {
    c.regime = options.regime;
    c.reason = fmt::format("{}: set by the options; {}", ToString(c.regime), depths);
    return c;
  }
  c.automatic = true;
  c.regime = c.depth_spread >= kForwardDepthSpread ? SlamRegime::kForward : SlamRegime::kNadir;
  c.reason = c.stereo_points < kRegimeMinStereoPoints
                 ? fmt::format("{}: {}", ToString(c.regime), depths)
                 : fmt::format("{}: {} {} x{:.0f}", ToString(c.regime), depths,
                               c.regime == SlamRegime::kForward ? ">=" : "<", kForwardDepthSpread);
  return c;
}

SlamOptions OptionsForRegime(const SlamOptions& options, SlamRegime regime) {
  SlamOptions o = options;
  if (regime != SlamRegime::kForward) return o;
  o.features = std::max(o.features, 2000);
  if (o.triangulation_neighbours == 0) o.triangulation_neighbours = 5;
  o.local_ba_iterations = std::min(o.local_ba_iterations, 5);
  o.local_ba_fixed_size = true;
  o.keyframe_max_gap = std::min(o.keyframe_max_gap, 5);
  return o;
}

}  // namespace rs
