#pragma once
// Options of the damage algorithms, registered once (survey/options.h) so the
// stage glue derives the survey.json keys, CLI flags and schema from them.
// Checked once where they enter (the stage's options, DetectDamage's callers,
// SegmentTransformedDisparity): the per-frame and per-instance functions take them checked.

#include "survey/grading/severity_rules.h"
#include "survey/options.h"

namespace rs {

/// Road surface model: robust quadratic surface in 3D with obstacle removal.
struct RoadModelOptions {
  int fit_stride_px = 6;            ///< sample every n-th pixel in u and v for the fit
  int ransac_iterations = 200;      ///< plane hypotheses tried to find the dominant surface
  double ransac_inlier_m = 0.03;    ///< plane inlier band for the hypothesis score, m
  double obstacle_height_m = 0.06;  ///< points this far above the road model are obstacles (cars, kerbs, people)
  int irls_iterations = 6;          ///< reweighting passes of the Tukey-robust quadratic fit
  double min_noise_m = 0.002;       ///< floor of the robust residual scale, m (keeps Tukey from collapsing)
  double delta_px = 30;             ///< δ added to the transformed disparity so the road sits at δ (as fan2019)
  unsigned random_seed = 1;         ///< RANSAC sampling seed (results are reproducible)
  /// Cell of the local correction of the quadratic model (robust median of road residuals per
  /// cell, damage excluded, smoothed): follows a crowned (roof-shaped) road; 0 = off.
  int local_cell_px = 24;
  /// Side of the normalised box filter (valid pixels only) applied to the transformed disparity
  /// and the depth below the road: averages stereo matching noise; 1 = off.
  int relief_smooth_px = 7;
  /// The smoothing window covers a square on the road with about relief_smooth_px² pixels:
  /// in an oblique view (car) it is shorter and wider on the image (relief_smooth.h). A square
  /// image window there spans 3-5× more road along the driving direction than across and
  /// smears foreshortened potholes' rims outwards; false: square on the image.
  bool relief_smooth_ground = true;
  /// Pixels whose transformed disparity differs from its smoothed value by more than this many
  /// σ (robust σ of that difference over the frame: the matching noise) keep their own values:
  /// the smoothing averages noise, not a pothole's rim or the occlusion edge at its near wall,
  /// which it would smear onto the road beside; 0 = off.
  double relief_smooth_edge_sigma = 16.0;
  /// Analysed range: disparities whose stereo depth uncertainty σ_Z = Z²·σ_d/(f·B) (σ_d =
  /// measure.sigma_disparity_px) exceeds this are dropped before the road fit (the far road of
  /// a forward-looking camera, where no depth can be measured, bends the model); 0 = keep all.
  double max_depth_sigma_m = 0.05;
  /// The analysed range never ends nearer than this multiple of the nearest road depth (the
  /// 2nd-percentile depth of the frame): a high or low-resolution nadir camera, whose whole
  /// road lies beyond the σ_Z limit, still has its road analysed (σ_Z is reported per damage).
  double min_range_factor = 1.5;
  /// Connected road regions (valid, not obstacle) smaller than this on the road are not road:
  /// islands of mismatched disparity on an untextured obstacle that land within the road band
  /// and read as deep "depressions" on a parked car (road_islands.h): depressions on them are
  /// removed after the segmentation and the crack search skips them; 0 = off, m².
  double min_region_m2 = 1.0;
  void Check() const;
  static const OptionTable<RoadModelOptions>& Table();
};

/// Unsupervised segmentation of depressions in a transformed disparity image.
struct SegmentOptions {
  double min_threshold_sigma = 4.0;   ///< threshold at least this many robust σ below the road level
  double max_threshold_sigma = 30.0;  ///< and at most this many (caps the energy-minimising threshold)
  /// Calibrated: cell of the local noise map (LocalReliefNoise): thresholds count in the σ of the
  /// region a pixel lies in, not one σ for the frame (stereo noise is not stationary), px; 0 = global σ.
  int noise_cell_px = 96;
  /// Calibrated, with the local noise map: a pixel at least this many local σ below the road seeds a
  /// region whatever the frame's threshold (deep potholes elsewhere raise that above shallow ones
  /// that stand out where they lie; the pothole noise rule's own k); 0 = off.
  double seed_noise_sigma = 8.0;
  /// Calibrated, with the left image and noise_cell_px > 0: pixels near strong intensity steps
  /// (paint edges; StrongEdgeMask), where the matcher may err by more than shallow damage, get
  /// their own local noise estimate: blurred gradient at least this many grey levels per px (0 = off) ...
  double edge_min_gradient = 10.0;
  int edge_margin_px = 6;        ///< ... and at most this far from such a step, px
  int slic_region_size_px = 16;  ///< SLIC superpixel size used to snap boundaries, px (0 = no SLIC)
  /// In oblique views (a pixel ≥ 1.5× longer on the road along the column than across) shape the
  /// superpixels square on the road (same pixel count): square image superpixels there span a
  /// small pothole's whole length along the view.
  bool slic_ground = true;
  double slic_ruler = 20.0;      ///< SLIC compactness
  double superpixel_vote = 0.4;  ///< fraction of below-threshold pixels that makes a superpixel damage
  double grow_fraction = 0.5;    ///< hysteresis: grow regions into pixels deeper than this fraction of the threshold
  double invalid_fill_fraction = 0.3;  ///< unmatched patches whose border is at least this fraction damage join it
  int morph_radius_px = 2;             ///< opening/closing radius, px
  /// Without calibration (a foreign transformed disparity): cell of the local road level
  /// (LocalReliefLevel), so ruts, sags and a crown the transformation left are road, not
  /// damage; 0 = one level per image, px.
  int level_cell_px = 32;
  /// Without calibration: an instance's wall (median slope over the 3 px inside its outline)
  /// must be this many times the road's slope noise σ (the road's own slopes have a median of
  /// 1.18 σ); broad sags and ruts the level did not follow are no steeper; 0 = off.
  double min_wall_steepness = 3.0;
  double rim_depth_m = 0.001;        ///< calibrated: rim extension threshold floor (raised to the local road noise), m
  double rim_depth_fraction = 0.03;  ///< calibrated: rim threshold at least this fraction of the instance's depth
  bool rim_ring_mean = true;   ///< calibrated: then grow by whole rings whose mean depth is significant (ExtendToRim)
  double min_area_m2 = 0.005;  ///< smallest damage kept when calibration is known, m²
  int min_area_px = 400;       ///< smallest damage kept without calibration, px
  void Check() const;
  static const OptionTable<SegmentOptions>& Table();
};

/// Thin dark ridges (cracks) in the left image.
struct CrackOptions {
  bool enabled = true;  ///< look for cracks at all
  /// Crack evidence: kLearned = the learned model's probability (crack_net.h) at its threshold;
  /// kRidge = multi-scale Hessian valley less the gradient, each scale in robust σ of its own
  /// texture, with hysteresis (ridge.h); kBlackHat = morphological black-hat with a local level
  /// and oriented line support; kAuto = kLearned in pixel units (no pixel sizes) on images up to
  /// 384 px a side (patches like its training data) when the model file exists, else the
  /// classical detector (kRidge in pixel units; with pixel sizes the metric black-hat): both
  /// measured better than the model on whole frames (docs/results/damage.md).
  enum class Detector { kAuto, kLearned, kRidge, kBlackHat };
  Detector detector = Detector::kAuto;
  /// The learned model (ONNX, with its .json beside it); empty = the committed model
  /// (stages/damage/cracks/model/crack_net.onnx in the source tree, else the installed copy).
  std::string model;
  /// Crack where the learned probability reaches this; 0 = the threshold chosen in training
  /// (the model's .json, picked on a hold-out of the training data).
  double learned_threshold = 0;
  /// Ridge scales without calibration: Gaussian σ from min to max in steps of √2; a dark line
  /// w px wide responds most at σ ≈ w/2 (2σ of the valley's curvature matches its width), px.
  double ridge_min_sigma_px = 1.0;
  double ridge_max_sigma_px = 16.0;
  double ridge_high_sigma = 3.0;  ///< hysteresis seed: ridge strength in robust σ of the texture
  double ridge_low_sigma = 2.5;   ///< hysteresis growth: ridge strength in robust σ
  /// The crack region: pixels within ridge_width_factor × (the ridge's best scale) of the
  /// centreline whose darkness below the background (median over 4 × the largest scale)
  /// reaches half the centreline's (full width at half depth).
  double ridge_width_factor = 1.5;
  int min_scale_px = 5;   ///< smallest black-hat structuring element, px (odd)
  int max_scale_px = 15;  ///< largest black-hat structuring element, px (odd)
  /// With pixel sizes on the road (calibrated): the black-hat element spans this much road
  /// (rounded to an odd pixel count per image row, clamped to [min_scale_px, max_scale_px]):
  /// dark lines narrower respond fully. A fixed pixel scale spans 4× more road near an oblique
  /// camera than far from it and there matched the gaps between coarse aggregate; 0 = pixel scales.
  double element_width_m = 0.03;
  double k_sigma = 5.0;  ///< response threshold: median + k·σ(MAD) of the black-hat response
  /// Cell of the local response level (median, MAD per cell, interpolated): texture resolved
  /// near the camera responds more than the blurred far road; 0 = one level per frame, px.
  int level_cell_px = 64;
  /// Oriented line support: pixels count as crack where the mean response along a line of this
  /// length (8 directions, best minus their mean) stands k_sigma above its local level, and the
  /// pixel's own response 1 σ above its level; 0 = the pixel response alone at k_sigma, px.
  int line_length_px = 21;
  /// Hysteresis along the line (with line_length_px > 0): pixels 8-connected to a detection join
  /// it where their response and their line support both stand this many σ above their levels.
  /// A crack's support dips along it (a hairline narrower than a pixel, a bend between the 8
  /// directions); half the detection level, as Canny's edges grow. k_sigma = no growth.
  double line_grow_sigma = 2.5;
  double min_length_m = 0.15;   ///< shorter thin components are texture, not cracks, m
  double min_elongation = 6.0;  ///< skeleton length / mean width below this is a blob, not a crack
  double max_width_m = 0.05;    ///< wider dark regions are not cracks, m
  int min_length_px = 40;       ///< without calibration: shortest crack, px
  void Check() const;
  static const OptionTable<CrackOptions>& Table();
};

/// Measurement and classification.
struct MeasureOptions {
  double sigma_disparity_px = 0.25;      ///< stereo matching noise σ_d used for σ_Z = Z²σ_d/(fB), px
  double pothole_min_depth_m = 0.013;    ///< shallower depressions are "other" (ASTM smallest graded depth)
  double pothole_min_diameter_m = 0.10;  ///< narrower depressions are "other" (ASTM smallest graded diameter)
  /// Width of the part at least half the max depth deep (largest inscribed circle): a deep but
  /// narrow crack, widened by segmentation, is not a pothole.
  double pothole_min_core_width_m = 0.05;
  /// Area / (π/4 · max diameter²) on the road plane: an elongated depression (a deep crack
  /// widened by segmentation and the oblique view) is not a pothole (bowl-shaped).
  double pothole_min_compactness = 0.3;
  /// Max depth must reach this many σ_Z (stereo depth noise at the instance's range): far
  /// depressions within the noise are "other".
  double pothole_min_depth_sigma = 1.0;
  /// Max depth must reach this many σ of the road's measured local noise (the LocalReliefNoise map
  /// of the segmentation, as depth below the surface, averaged over the instance; needs
  /// segment.noise_cell_px > 0): a depression no deeper than the ripples around it is not
  /// confirmed as a pothole. 0 = off.
  double pothole_min_noise_sigma = 8.0;
  /// That noise capped at twice the spread below the road level (TwoSidedReliefNoise): matching
  /// noise errs both ways, a kerb's or verge's rise the road model does not follow only up.
  bool pothole_noise_two_sided = true;
  /// Max depth must also reach this multiple of how far the road's upward errors reach around it
  /// (LocalReliefSpikes: the spike_quantile of the upward deviations per noise cell): SGM's wrong
  /// winners fake depressions as deep as they fake bumps, real damage only goes down. 0 = off.
  double pothole_min_spike_ratio = 2.0;
  /// Calibrated: quantile of a noise cell's upward deviations taken as its error reach (0.999 of
  /// the ~500 samples of a 96 px cell: about its largest).
  double spike_quantile = 0.999;
  double depth_percentile = 0.99;  ///< max depth = this percentile of per-pixel depth (rejects single-pixel spikes)
  /// Line of sight over the near rim (floor_visibility.h): the floor counts as seen when the
  /// deepest seen surface reaches this many image rows of clearance (Z/f each) farther from the
  /// rim's shadow line than where it begins; else it may be hidden and the depth is a lower bound.
  double floor_clearance_px = 8.0;
  /// Hidden floor: walls in the rim's shadow assumed no steeper on average (depth per metre)
  /// than this; bounds the hidden depth (vertical walls would leave it unbounded).
  double hidden_wall_slope = 1.0;
  /// Calibrated (measurement_sigma.h): outline position uncertainty where the depression is far
  /// deeper than the stereo noise, px (our disparity's blur of the walls: a toe on the road
  /// beside one wall, a shallower band inside another).
  double outline_sigma_px = 1.5;
  /// Calibrated: the wall's depth profile spread over about this many pixels, so the stereo noise
  /// moves the outline by outline_blur_px · σ_Z / max depth more, px.
  double outline_blur_px = 3.0;
  /// Depth errors of neighbouring pixels are correlated over the matcher's window (the 9×9
  /// refinement): the volume's noise averages over patches of this size, px.
  double depth_noise_correlation_px = 9.0;
  void Check() const;
  static const OptionTable<MeasureOptions>& Table();
};

}  // namespace rs
