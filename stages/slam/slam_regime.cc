#include "stages/slam/slam_regime.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

namespace rs {
namespace {

double Percentile(std::vector<float> v, double q) {
  const size_t k = static_cast<size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::string DepthText(const RegimeChoice& c) {
  if (c.stereo_points < kRegimeMinStereoPoints)
    return fmt::format("first frame has {} stereo points (< {})", c.stereo_points, kRegimeMinStereoPoints);
  return fmt::format("first frame's stereo depths span {:.1f}-{:.1f} m (x{:.2f} {} x{:.1f})", c.depth_p10_m,
                     c.depth_p90_m, c.depth_spread, c.depth_spread >= kForwardDepthSpread ? ">=" : "<",
                     kForwardDepthSpread);
}

}  // namespace

RegimeChoice ChooseRegimeFromDepths(const SlamOptions& options, const StereoFeatures& first_frame) {
  RegimeChoice c;
  std::vector<float> depth;
  for (float d : first_frame.depth_m)
    if (d > 0) depth.push_back(d);
  c.stereo_points = static_cast<int>(depth.size());
  if (c.stereo_points >= kRegimeMinStereoPoints) {
    c.depth_p10_m = Percentile(depth, 0.1);
    c.depth_p50_m = Percentile(depth, 0.5);
    c.depth_p90_m = Percentile(depth, 0.9);
    c.depth_spread = c.depth_p90_m / c.depth_p10_m;
  }
  if (options.regime != SlamRegime::kAuto) {
    c.regime = options.regime;
    c.decided = true;
    c.reason = fmt::format("{}: set by the options; {}", ToString(c.regime), DepthText(c));
    return c;
  }
  c.automatic = true;
  c.decided = c.depth_spread >= kForwardDepthSpread;
  c.regime = c.decided ? SlamRegime::kForward : SlamRegime::kNadir;
  c.reason = fmt::format("{}: {}", ToString(c.regime), DepthText(c));
  return c;
}

bool DecideRegimeFromMotion(RegimeChoice* c, const Eigen::Vector3d& t, int frame_index) {
  if (c->decided) return true;
  const double moved = t.norm();
  const bool enough = c->depth_p50_m > 0 && moved >= kRegimeMinMotionShareOfDepth * c->depth_p50_m;
  if (!enough && frame_index < kRegimeLastFrame) return false;
  c->decided = true;
  if (!enough) {
    c->regime = SlamRegime::kNadir;
    c->reason = fmt::format("nadir: {}; camera moved {:.3f} m by frame {} (< {:.0f} % of the median depth)",
                            DepthText(*c), moved, frame_index, 100 * kRegimeMinMotionShareOfDepth);
    return true;
  }
  c->forward_share = std::abs(t.z()) / moved;
  c->regime = c->forward_share >= kForwardMotionShare ? SlamRegime::kForward : SlamRegime::kNadir;
  c->reason = fmt::format(
      "{}: {}; camera motion along its optical axis |t_z|/|t| = {:.2f} ({} {:.1f}) over "
      "{:.2f} m to frame {}",
      ToString(c->regime), DepthText(*c), c->forward_share, c->regime == SlamRegime::kForward ? ">=" : "<",
      kForwardMotionShare, moved, frame_index);
  return true;
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
