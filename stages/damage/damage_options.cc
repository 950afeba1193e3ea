#include "stages/damage/damage_options.h"

#include "stages/damage/cracks/crack_net.h"

#include <fmt/format.h>

#include <filesystem>

namespace rs {
namespace {

// "damage.<a> = x violates <a> <op> <b> (<b> = y)".
void Require(bool ok, const char* a, double va, const char* op, const char* b, double vb) {
  if (!ok) throw OptionError(fmt::format("damage.{} = {} violates {} {} {} ({} = {})", a, va, a, op, b, b, vb));
}

}  // namespace

void RoadModelOptions::Check() const {
  Require(fit_stride_px >= 1, "fit_stride_px", fit_stride_px, ">=", "1", 1);
  Require(ransac_iterations >= 1, "ransac_iterations", ransac_iterations, ">=", "1", 1);
  Require(ransac_inlier_m > 0, "ransac_inlier_m", ransac_inlier_m, ">", "0", 0);
  Require(obstacle_height_m > ransac_inlier_m, "obstacle_height_m", obstacle_height_m, ">", "ransac_inlier_m",
          ransac_inlier_m);
  Require(irls_iterations >= 1, "irls_iterations", irls_iterations, ">=", "1", 1);
  Require(min_noise_m > 0, "min_noise_m", min_noise_m, ">", "0", 0);
  Require(delta_px >= 0, "delta_px", delta_px, ">=", "0", 0);
  Require(local_cell_px >= 0, "local_cell_px", local_cell_px, ">=", "0", 0);
  Require(relief_smooth_px >= 1, "relief_smooth_px", relief_smooth_px, ">=", "1", 1);
  Require(relief_smooth_edge_sigma >= 0, "relief_smooth_edge_sigma", relief_smooth_edge_sigma, ">=", "0", 0);
  Require(max_depth_sigma_m >= 0, "max_depth_sigma_m", max_depth_sigma_m, ">=", "0", 0);
  Require(min_range_factor >= 1, "min_range_factor", min_range_factor, ">=", "1", 1);
  Require(min_region_m2 >= 0, "min_region_m2", min_region_m2, ">=", "0", 0);
}

const OptionTable<RoadModelOptions>& RoadModelOptions::Table() {
  using O = RoadModelOptions;
  static const auto table =
      OptionTable<O>()
          .Add("fit_stride_px", &O::fit_stride_px, "sample every n-th pixel for the road fit", "px")
          .Min(1)
          .Add("ransac_iterations", &O::ransac_iterations, "plane hypotheses for the dominant road surface")
          .Min(1)
          .Add("ransac_inlier_m", &O::ransac_inlier_m, "plane inlier band for the hypothesis score", "m")
          .Above(0)
          .Add("obstacle_height_m", &O::obstacle_height_m, "points this far above the road are obstacles", "m")
          .Above(0)
          .Add("irls_iterations", &O::irls_iterations, "reweighting passes of the robust quadratic fit")
          .Min(1)
          .Add("min_noise_m", &O::min_noise_m, "floor of the robust residual scale", "m")
          .Above(0)
          .Add("delta_px", &O::delta_px, "road level of the transformed disparity", "px")
          .Min(0)
          .Add("random_seed", &O::random_seed, "RANSAC sampling seed")
          .Min(0)
          .Add("local_cell_px", &O::local_cell_px, "cell of the local road-model correction (0 = off)", "px")
          .Min(0)
          .Add("relief_smooth_px", &O::relief_smooth_px, "box filter of the relief against stereo noise (1 = off)",
               "px")
          .Min(1)
          .Add("relief_smooth_ground", &O::relief_smooth_ground,
               "shape the relief smoothing window to a square on the road (oblique views: shorter, wider on the image)")
          .Add("relief_smooth_edge_sigma", &O::relief_smooth_edge_sigma,
               "pixels differing from their smoothed value by more than this many noise sigma keep their own (0 = off)")
          .Min(0)
          .Add("max_depth_sigma_m", &O::max_depth_sigma_m,
               "analysed range: drop disparities whose depth uncertainty sigma_Z exceeds this (0 = all)", "m")
          .Min(0)
          .Add("min_range_factor", &O::min_range_factor,
               "the analysed range reaches at least this multiple of the frame's nearest road depth")
          .Min(1)
          .Add("min_region_m2", &O::min_region_m2,
               "connected road regions smaller than this are not road: mismatched islands on obstacles (0 = off)", "m2")
          .Min(0);
  return table;
}

void SegmentOptions::Check() const {
  Require(min_threshold_sigma > 0, "min_threshold_sigma", min_threshold_sigma, ">", "0", 0);
  Require(max_threshold_sigma >= min_threshold_sigma, "max_threshold_sigma", max_threshold_sigma,
          ">=", "min_threshold_sigma", min_threshold_sigma);
  Require(grow_fraction > 0 && grow_fraction <= 1, "grow_fraction", grow_fraction, "in", "(0, 1]", 1);
  Require(slic_region_size_px == 0 || slic_region_size_px >= 4, "slic_region_size_px", slic_region_size_px,
          ">=", "4 (or 0 = off)", 4);
  Require(noise_cell_px == 0 || noise_cell_px >= 4, "noise_cell_px", noise_cell_px, ">=", "4 (or 0 = off)", 4);
  Require(seed_noise_sigma == 0 || seed_noise_sigma >= min_threshold_sigma, "seed_noise_sigma", seed_noise_sigma,
          ">=", "min_threshold_sigma (or 0 = off)", min_threshold_sigma);
  Require(edge_min_gradient >= 0, "edge_min_gradient", edge_min_gradient, ">=", "0", 0);
  Require(edge_margin_px >= 0, "edge_margin_px", edge_margin_px, ">=", "0", 0);
  Require(slic_ruler > 0, "slic_ruler", slic_ruler, ">", "0", 0);
  Require(superpixel_vote > 0 && superpixel_vote < 1, "superpixel_vote", superpixel_vote, "in", "(0, 1)", 0);
  Require(invalid_fill_fraction > 0 && invalid_fill_fraction <= 1, "invalid_fill_fraction", invalid_fill_fraction, "in",
          "(0, 1]", 1);
  Require(morph_radius_px >= 0, "morph_radius_px", morph_radius_px, ">=", "0", 0);
  Require(level_cell_px == 0 || level_cell_px >= 8, "level_cell_px", level_cell_px, ">=", "8 (or 0 = off)", 8);
  Require(min_wall_steepness >= 0, "min_wall_steepness", min_wall_steepness, ">=", "0", 0);
  Require(rim_depth_m > 0, "rim_depth_m", rim_depth_m, ">", "0", 0);
  Require(rim_depth_fraction >= 0 && rim_depth_fraction < 1, "rim_depth_fraction", rim_depth_fraction, "in", "[0, 1)",
          0);
  Require(min_area_m2 >= 0, "min_area_m2", min_area_m2, ">=", "0", 0);
  Require(min_area_px >= 1, "min_area_px", min_area_px, ">=", "1", 1);
}

const OptionTable<SegmentOptions>& SegmentOptions::Table() {
  using O = SegmentOptions;
  static const auto table =
      OptionTable<O>()
          .Add("min_threshold_sigma", &O::min_threshold_sigma, "threshold at least this many σ below the road")
          .Above(0)
          .Add("max_threshold_sigma", &O::max_threshold_sigma, "threshold at most this many σ below the road")
          .Above(0)
          .Add("noise_cell_px", &O::noise_cell_px,
               "calibrated: cell of the local noise map thresholds are counted in (0 = one global σ)", "px")
          .Min(0)
          .Add("seed_noise_sigma", &O::seed_noise_sigma,
               "calibrated: pixels this many local σ below the road seed a region whatever the frame's threshold (0 = "
               "off)")
          .Min(0)
          .Add("edge_min_gradient", &O::edge_min_gradient,
               "calibrated: pixels near image steps this strong (blurred, grey levels/px; paint edges) get their own "
               "local noise (0 = off)")
          .Min(0)
          .Add("edge_margin_px", &O::edge_margin_px, "distance from such a step of those pixels", "px")
          .Min(0)
          .Add("slic_region_size_px", &O::slic_region_size_px, "SLIC superpixel size (0 = off)", "px")
          .Min(0)
          .Add("slic_ground", &O::slic_ground,
               "oblique views: SLIC superpixels square on the road (same pixel count), not on the image")
          .Add("slic_ruler", &O::slic_ruler, "SLIC compactness")
          .Above(0)
          .Add("superpixel_vote", &O::superpixel_vote, "below-threshold fraction making a superpixel damage")
          .Above(0)
          .Below(1)
          .Add("grow_fraction", &O::grow_fraction, "hysteresis growth level, fraction of the threshold")
          .Above(0)
          .Max(1)
          .Add("invalid_fill_fraction", &O::invalid_fill_fraction,
               "border fraction of damage that absorbs an unmatched patch")
          .Above(0)
          .Max(1)
          .Add("morph_radius_px", &O::morph_radius_px, "opening/closing radius", "px")
          .Min(0)
          .Add("level_cell_px", &O::level_cell_px,
               "without calibration: cell of the local road level that follows ruts and sags (0 = one level)", "px")
          .Min(0)
          .Add("min_wall_steepness", &O::min_wall_steepness,
               "without calibration: an instance's wall slope at least this many road slope-noise sigma (0 = off)")
          .Min(0)
          .Add("rim_depth_m", &O::rim_depth_m,
               "calibrated rim extension depth, floor of the local road noise threshold", "m")
          .Above(0)
          .Add("rim_depth_fraction", &O::rim_depth_fraction,
               "calibrated rim threshold at least this fraction of the instance's depth")
          .Min(0)
          .Below(1)
          .Add("rim_ring_mean", &O::rim_ring_mean,
               "calibrated: then grow by whole one-pixel rings whose mean depth is significant")
          .Add("min_area_m2", &O::min_area_m2, "smallest damage kept (calibrated)", "m2")
          .Min(0)
          .Add("min_area_px", &O::min_area_px, "smallest damage kept (uncalibrated)", "px")
          .Min(1);
  return table;
}

void CrackOptions::Check() const {
  Require(min_scale_px >= 3 && min_scale_px % 2 == 1, "min_scale_px", min_scale_px, ">=", "3 and odd", 3);
  Require(max_scale_px >= min_scale_px && max_scale_px % 2 == 1, "max_scale_px", max_scale_px,
          ">=", "min_scale_px (odd)", min_scale_px);
  Require(element_width_m >= 0, "element_width_m", element_width_m, ">=", "0", 0);
  Require(k_sigma > 0, "k_sigma", k_sigma, ">", "0", 0);
  Require(level_cell_px == 0 || level_cell_px >= 16, "level_cell_px", level_cell_px, ">=", "16 (or 0)", 16);
  Require(line_length_px == 0 || line_length_px >= 5, "line_length_px", line_length_px, ">=", "5 (or 0)", 5);
  Require(line_grow_sigma > 0, "line_grow_sigma", line_grow_sigma, ">", "0", 0);
  Require(line_grow_sigma <= k_sigma, "line_grow_sigma", line_grow_sigma, "<=", "k_sigma", k_sigma);
  Require(min_length_m > 0, "min_length_m", min_length_m, ">", "0", 0);
  Require(min_elongation >= 1, "min_elongation", min_elongation, ">=", "1", 1);
  Require(max_width_m > 0, "max_width_m", max_width_m, ">", "0", 0);
  Require(min_length_px >= 2, "min_length_px", min_length_px, ">=", "2", 2);
  Require(ridge_max_sigma_px >= ridge_min_sigma_px, "ridge_max_sigma_px", ridge_max_sigma_px,
          ">=", "ridge_min_sigma_px", ridge_min_sigma_px);
  if (detector == Detector::kLearned) {
    const std::filesystem::path path = ResolveCrackModelPath(model);
    if (!std::filesystem::is_regular_file(path))
      throw OptionError(fmt::format("damage.detector = learned needs the crack model, not found: {}", path.string()));
  }
  Require(learned_threshold >= 0, "learned_threshold", learned_threshold, ">=", "0", 0);
  Require(learned_threshold < 1, "learned_threshold", learned_threshold, "<", "1", 1);
  Require(ridge_high_sigma >= ridge_low_sigma, "ridge_high_sigma", ridge_high_sigma, ">=", "ridge_low_sigma",
          ridge_low_sigma);
}

const OptionTable<CrackOptions>& CrackOptions::Table() {
  using O = CrackOptions;
  static const auto table =
      OptionTable<O>()
          .Add("enabled", &O::enabled, "look for cracks")
          .AddEnum("detector", &O::detector,
                   {{"auto", O::Detector::kAuto},
                    {"learned", O::Detector::kLearned},
                    {"ridge", O::Detector::kRidge},
                    {"black-hat", O::Detector::kBlackHat},
                    {"blackhat", O::Detector::kBlackHat}},  // the earlier spelling, still read
                   "crack evidence: learned model (probability at its threshold), multi-scale Hessian ridge with "
                   "hysteresis, or morphological black-hat; auto = learned on patches up to 384 px without "
                   "calibration when the model file exists, else classical")
          .Add("model", &O::model,
               "learned crack model (ONNX, its .json beside it); empty = the committed "
               "stages/damage/cracks/model/crack_net.onnx")
          .Add("learned_threshold", &O::learned_threshold,
               "learned crack probability threshold (0 = the model's, chosen on a training hold-out)")
          .Min(0)
          .Below(1)
          .Add("ridge_min_sigma_px", &O::ridge_min_sigma_px, "smallest ridge scale without calibration (Gaussian σ)",
               "px")
          .Above(0)
          .Add("ridge_max_sigma_px", &O::ridge_max_sigma_px, "largest ridge scale without calibration (Gaussian σ)",
               "px")
          .Above(0)
          .Add("ridge_high_sigma", &O::ridge_high_sigma, "ridge hysteresis seed level, robust σ of the texture")
          .Above(0)
          .Add("ridge_low_sigma", &O::ridge_low_sigma, "ridge hysteresis growth level, robust σ of the texture")
          .Above(0)
          .Add("ridge_width_factor", &O::ridge_width_factor,
               "crack region: within this many ridge scales of the centreline, down to half its darkness")
          .Above(0)
          .Add("min_scale_px", &O::min_scale_px, "smallest black-hat element (odd)", "px")
          .Min(3)
          .Add("max_scale_px", &O::max_scale_px, "largest black-hat element (odd)", "px")
          .Min(3)
          .Add("element_width_m", &O::element_width_m,
               "calibrated: black-hat element width on the road, per image row within the pixel scales (0 = pixel "
               "scales)",
               "m")
          .Min(0)
          .Add("k_sigma", &O::k_sigma, "black-hat threshold in robust σ")
          .Above(0)
          .Add("level_cell_px", &O::level_cell_px, "cell of the local black-hat level (0 = one per frame)", "px")
          .Min(0)
          .Add("line_length_px", &O::line_length_px,
               "oriented line support length: response averaged along lines must stand out (0 = pixel response alone)",
               "px")
          .Min(0)
          .Add("line_grow_sigma", &O::line_grow_sigma,
               "hysteresis along a crack: connected pixels whose response and line support stand this many σ above "
               "their levels join a detection (k_sigma = no growth)")
          .Above(0)
          .Add("min_length_m", &O::min_length_m, "shortest crack", "m")
          .Above(0)
          .Add("min_elongation", &O::min_elongation,
               "length / width below this is not a crack (the learned model carries its own)")
          .Min(1)
          .Add("max_width_m", &O::max_width_m, "wider dark regions are not cracks", "m")
          .Above(0)
          .Add("min_length_px", &O::min_length_px,
               "shortest crack without calibration (the learned model carries its own)", "px")
          .Min(2);
  return table;
}

void MeasureOptions::Check() const {
  Require(sigma_disparity_px > 0, "sigma_disparity_px", sigma_disparity_px, ">", "0", 0);
  Require(pothole_min_depth_m >= 0, "pothole_min_depth_m", pothole_min_depth_m, ">=", "0", 0);
  Require(pothole_min_diameter_m >= 0, "pothole_min_diameter_m", pothole_min_diameter_m, ">=", "0", 0);
  Require(pothole_min_core_width_m >= 0, "pothole_min_core_width_m", pothole_min_core_width_m, ">=", "0", 0);
  Require(pothole_min_compactness >= 0 && pothole_min_compactness <= 1, "pothole_min_compactness",
          pothole_min_compactness, "in", "[0, 1]", 0);
  Require(pothole_min_depth_sigma >= 0, "pothole_min_depth_sigma", pothole_min_depth_sigma, ">=", "0", 0);
  Require(pothole_min_noise_sigma >= 0, "pothole_min_noise_sigma", pothole_min_noise_sigma, ">=", "0", 0);
  Require(pothole_min_spike_ratio >= 0, "pothole_min_spike_ratio", pothole_min_spike_ratio, ">=", "0", 0);
  Require(spike_quantile > 0.5, "spike_quantile", spike_quantile, ">", "0.5", 0.5);
  Require(spike_quantile < 1, "spike_quantile", spike_quantile, "<", "1", 1);
  Require(depth_percentile > 0.5 && depth_percentile <= 1, "depth_percentile", depth_percentile, "in", "(0.5, 1]", 0);
  Require(floor_clearance_px >= 0, "floor_clearance_px", floor_clearance_px, ">=", "0", 0);
  Require(hidden_wall_slope > 0, "hidden_wall_slope", hidden_wall_slope, ">", "0", 0);
  Require(outline_sigma_px >= 0, "outline_sigma_px", outline_sigma_px, ">=", "0", 0);
  Require(outline_blur_px >= 0, "outline_blur_px", outline_blur_px, ">=", "0", 0);
  Require(depth_noise_correlation_px >= 1, "depth_noise_correlation_px", depth_noise_correlation_px, ">=", "1", 1);
}

const OptionTable<MeasureOptions>& MeasureOptions::Table() {
  using O = MeasureOptions;
  static const auto table =
      OptionTable<O>()
          .Add("sigma_disparity_px", &O::sigma_disparity_px, "stereo matching noise σ_d", "px")
          .Above(0)
          .Add("pothole_min_depth_m", &O::pothole_min_depth_m, "shallower depressions are 'other'", "m")
          .Min(0)
          .Add("pothole_min_diameter_m", &O::pothole_min_diameter_m, "narrower depressions are 'other'", "m")
          .Min(0)
          .Add("pothole_min_core_width_m", &O::pothole_min_core_width_m,
               "depressions whose half-max-depth core is narrower are 'other' (cracks)", "m")
          .Min(0)
          .Add("pothole_min_compactness", &O::pothole_min_compactness,
               "depressions with area / (pi/4 max diameter^2) below this are 'other' (elongated: cracks)")
          .Min(0)
          .Max(1)
          .Add("pothole_min_depth_sigma", &O::pothole_min_depth_sigma,
               "depressions shallower than this many sigma_Z are 'other'")
          .Min(0)
          .Add("pothole_min_noise_sigma", &O::pothole_min_noise_sigma,
               "depressions shallower than this many sigma of the local relief noise are 'other' (0 = off)")
          .Min(0)
          .Add("pothole_noise_two_sided", &O::pothole_noise_two_sided,
               "that noise capped at twice its spread below the road level (a kerb's rise is not matching noise)")
          .Add("pothole_min_spike_ratio", &O::pothole_min_spike_ratio,
               "depressions shallower than this multiple of the road's local upward error reach are 'other' "
               "(needs pothole_min_noise_sigma > 0; 0 = off)")
          .Min(0)
          .Add("spike_quantile", &O::spike_quantile,
               "quantile of a noise cell's upward deviations taken as its error reach")
          .Above(0.5)
          .Below(1)
          .Add("depth_percentile", &O::depth_percentile, "percentile of depth reported as max depth")
          .Above(0.5)
          .Max(1)
          .Add("floor_clearance_px", &O::floor_clearance_px,
               "the floor counts as seen when its deepest seen part reaches this many image rows (Z/f each) farther "
               "from the near rim's shadow line than where it begins",
               "px")
          .Min(0)
          .Add("hidden_wall_slope", &O::hidden_wall_slope,
               "hidden floor: walls in the near rim's shadow assumed no steeper on average (bounds the hidden depth)")
          .Above(0)
          .Add("outline_sigma_px", &O::outline_sigma_px,
               "calibrated outline position uncertainty of a depression far deeper than the stereo noise "
               "(sigma_area_m2, sigma_volume_m3)",
               "px")
          .Min(0)
          .Add("outline_blur_px", &O::outline_blur_px,
               "calibrated width of a wall's spread depth: the outline uncertainty grows by this times sigma_Z / max "
               "depth",
               "px")
          .Min(0)
          .Add("depth_noise_correlation_px", &O::depth_noise_correlation_px,
               "depth errors correlated over patches this wide (the matcher's window): the volume's noise averages "
               "over the patches",
               "px")
          .Min(1);
  return table;
}

}  // namespace rs
