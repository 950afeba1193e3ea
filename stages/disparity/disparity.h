#pragma once
// Dense road disparity: plain SGM or GPT-SGM (road model -> perspective transformation ->
// SGM over a small residual range -> true and transformed disparity). docs/stages/disparity.md.

#include <opencv2/core/mat.hpp>

#include "stages/disparity/road_model.h"
#include "stages/disparity/sgm.h"

namespace rs {

/// Which matcher ComputeDisparity runs.
enum class DisparityMethod {
  kSgm,     ///< SGM over [min_disparity, min_disparity + num_disparities)
  kGptSgm,  ///< road model + perspective transformation + SGM over gpt_num_disparities
};

/// Parameters of the disparity computation. Defaults suit 8-bit rectified road imagery.
struct DisparityParams {
  DisparityMethod method = DisparityMethod::kGptSgm;  ///< matcher
  int min_disparity = 0;                              ///< plain SGM (and GPT fallback): smallest disparity, px
  int num_disparities = 128;                          ///< plain SGM (and GPT fallback): number of disparities, 1..1024

  /// Gaussian blur of both images before the census, px (0 = off): lifts the census above sensor
  /// noise on weakly textured, far road (docs/stages/disparity.md).
  double presmooth_sigma_px = 1.0;
  int census_width = 9;        ///< census window width, odd; width*height <= 65
  int census_height = 7;       ///< census window height, odd
  int ad_weight = 0;           ///< weight of the truncated absolute-difference term (0 = census only)
  int ad_truncation = 20;      ///< truncation of |IL - IR|, grey levels
  int num_paths = 4;           ///< SGM aggregation paths: 4 (horizontal + vertical; default, ~half the cost) or 8
  int p1 = 20;                 ///< SGM penalty for +-1 px disparity changes
  int p2 = 240;                ///< SGM penalty for larger changes; p1 < p2 <= 1900
  bool adaptive_p2 = true;     ///< P2' = max(P1, P2 * g / (|dI| + g)) lets disparity jump at intensity edges
  int p2_gradient_scale = 16;  ///< g in the adaptive P2, grey levels
  int uniqueness_ratio = 5;    ///< percent margin the best cost needs over non-neighbouring ones
  SubpixelMode subpixel = SubpixelMode::kEquiangular;  ///< sub-pixel refinement
  int lr_max_diff = 2;                                 ///< left-right consistency tolerance, px; < 0 disables
  int speckle_window_size =
      100;  ///< drop 4-connected regions (|step| <= speckle_max_diff_px) smaller than this; 0 = off
  double speckle_max_diff_px = 1.0;  ///< disparity step allowed inside a speckle region, px
  bool median = true;                ///< 3x3 median over valid neighbours (invalid pixels stay invalid)
  /// Fill an invalid pixel with the (lower) median of its valid 3x3 neighbours when at least this
  /// many of the 8 are valid and they agree within speckle_max_diff_px (isolated rejections by the
  /// uniqueness or left-right check on textured surfaces); 0 = off. Larger holes stay invalid.
  int fill_min_neighbours = 6;
  /// Intensity sub-pixel refinement (RefineSubpixel) over refine_window x refine_window pixels,
  /// odd; 0 = off (SGM's cost-curve sub-pixel stays). Removes SGM's pixel locking.
  int refine_window = 9;
  /// GPT-SGM: a second refinement over this larger window (odd, <= 63; 0 = off), taken where it
  /// agrees with refine_window's value within refine_smooth_agree_px and the surface is at most
  /// 1 px above the road model: matching noise peaks where the true disparity is half-way between
  /// integers (the views sample the texture at different phases), and a larger window averages it.
  int refine_smooth_window = 21;
  double refine_smooth_agree_px =
      0.2;  ///< largest difference to refine_window's value where the smooth window is taken, px
  /// With refine_smooth_window: pixels whose refine_window window is dominated by one straight,
  /// mostly vertical edge (structure-tensor coherence above this; ~0.3 on texture) give no terms to
  /// the smooth window and take its value: a hard shadow or paint edge is matched where each
  /// camera's pixel grid cut it, an error that does not average out along the edge. 1 = off.
  double refine_max_coherence = 0.7;
  /// Box of the local mean the refinement subtracts from both images (odd, >= 3): the views'
  /// gain and vignetting differ. Next to a strong step (a paint or shadow edge) the subtracted
  /// mean makes a ramp reaching refine_highpass_px / 2 from the edge, where the match then rests
  /// on the edge's position in each view's pixel grid; a small box keeps the ramp inside the edge
  /// band refine_max_coherence handles.
  int refine_highpass_px = 9;
  /// Shiftable smooth windows (refine_smooth_window): where a pixel's centred window fits its
  /// pixels' disparities this many times worse (G^2-weighted spread) than the best of the 8
  /// same-sized windows that hold the pixel at their edge or corner (and whose value is no farther
  /// from refine_window's), that window's value is taken: the centred window straddles a depth
  /// change (a pothole's wall) and would spread the far side's disparity up to 10 px onto the
  /// road. 0 = off; else >= 1.
  double refine_shift_ratio = 4.0;
  /// GPT-SGM with camera_focal_px: the refine_window window's height shrinks to a square on the
  /// road (its width kept; at least 5 rows): an oblique view foreshortens the road along the
  /// rows (a ground square at depression angle a is sin a as tall as wide: 0.2-0.3 at the car's
  /// 5-7 m), and a square window then spans a pothole's near and far walls and spreads them.
  /// Nadir views keep the square window.
  bool refine_ground_window = true;
  /// Focal length of the rectified pair, px: set by the caller from the calibration (not a
  /// survey option); 0 = unknown (refine_ground_window then has no effect).
  double camera_focal_px = 0;

  int gpt_num_disparities = 32;  ///< GPT-SGM residual search range, px (road residual + damage depth)
  double gpt_delta_px = 8;       ///< delta: residual disparity of the road's row minimum; damage down to -delta fits
  double gpt_headroom_px = 8;    ///< range kept above the road's largest residual (obstacles, kerbs)
  /// Widen gpt_num_disparities when delta + road span along a row + headroom exceeds it (strong roll).
  bool gpt_expand_range = true;
  /// true: warp the target by the exact sub-pixel kappa (MISSION eq. 1, linear interpolation);
  /// false: shift rows by floor(kappa) inside SGM (no resampling).
  bool gpt_subpixel_warp = true;
  /// With gpt_subpixel_warp: shift every pixel by its own road disparity (road(u, v) - delta) instead
  /// of each row by its minimum, so the road's residual is delta everywhere (no pixel locking there).
  bool gpt_pixel_warp = true;
  /// Safeguard against a wrong road model (a non-road plane, obstacles): when fewer than this share
  /// of the textured pixels whose road point is visible in the right view get a valid GPT-SGM
  /// disparity, plain SGM is run instead (fell_back = true). 0 disables.
  double gpt_min_valid_fraction = 0.9;
  /// GPT-SGM with camera_focal_px: a road model tilted further than this across the image rows
  /// (RoadLateralTiltRad, the rig's roll against the road) is not a road seen by a survey platform and
  /// is rejected (plain SGM fallback), deg; 0 = off. 50 = a platform tilted at most 45 deg (a multirotor's
  /// largest commanded tilt, PX4 MPC_TILTMAX_AIR; a car's body roll is a few degrees) on a road with a
  /// cross slope of at most 5 deg (8 % superelevation is 4.6 deg), image rows mounted level on the platform.
  double max_road_tilt_deg = 50;
  /// GPT fallback: plain SGM over the sparse matches' disparity range (DisparityRangeOfMatches, widened
  /// by gpt_headroom_px) instead of [min_disparity, min_disparity + num_disparities), when at least
  /// road.min_inliers matches were found; fewer: the configured range.
  bool fallback_range_from_matches = true;
  RoadFitOptions road;  ///< sparse matching and robust road-model fit

  /// Throws std::invalid_argument naming the rule broken, e.g. "disparity.p2 = 5 violates p2 > p1 (p1 = 8)".
  void Check() const;
  /// The SGM parameters for a run over [min_d, min_d + num_d).
  SgmParams ToSgm(int min_d, int num_d) const;
};

/// Wall times of the steps, ms.
struct DisparityTimings {
  double road_model_ms = 0;   ///< sparse matching + robust fit (GPT) or dense fit (SGM)
  double warp_ms = 0;         ///< kappa + target warp + pre-smoothing
  double census_ms = 0;       ///< both census transforms
  double aggregation_ms = 0;  ///< cost + path aggregation (+ winner-takes-all with 4 paths: fused into the last path)
  double wta_ms = 0;          ///< left-right check (+ winner-takes-all, uniqueness, sub-pixel with 8 paths)
  double postprocess_ms = 0;  ///< speckle filter + median
  double transform_ms = 0;    ///< true and transformed disparity maps
  double total_ms = 0;        ///< whole ComputeDisparity call
};

/// Output of ComputeDisparity.
struct DisparityResult {
  cv::Mat disparity;  ///< true disparity, CV_32F px, left view; 0 where invalid
  cv::Mat
      transformed;  ///< transformed disparity d - road(u, v) + delta, CV_32F; 0 where invalid or no reliable road model
  cv::Mat valid;    ///< CV_8U, 255 where disparity is valid
  /// GPT-SGM with refine_smooth_window: the true disparity of the refine_window pass alone (before
  /// the smooth window's value is taken; same post-processing, same validity as `disparity`).
  /// Noisier on the road, but a pothole's wall stays where it is: the smooth window spreads a
  /// sloping wall's depth onto the road and makes the floor beside it shallower
  /// (docs/stages/disparity.md, "Two images"). Empty when no smooth window ran (equal to `disparity`).
  cv::Mat disparity_sharp;
  RoadModel road;                                       ///< road model used (GPT) or fitted to the dense result (SGM)
  DisparityMethod method_used = DisparityMethod::kSgm;  ///< kSgm also when GPT fell back
  bool fell_back = false;     ///< GPT requested but road model unreliable -> plain SGM over the wide range
  int min_disparity = 0;      ///< smallest disparity searched (plain SGM), px; 0 for GPT-SGM's residual range
  int num_disparities = 0;    ///< disparities searched per pixel
  /// Lateral tilt of the sparse road model (RoadLateralTiltRad), rad; NaN without camera_focal_px.
  double road_tilt_rad = 0;
  bool road_tilt_rejected = false;  ///< the road model exceeded max_road_tilt_deg (then fell_back)
  double valid_fraction = 0;  ///< share of valid pixels
  DisparityTimings timings;
};

/// Computes the dense disparity of a rectified 8-bit grey pair (left = reference).
/// `prior`: the previous frame's road model, seeds and validates the robust fit.
/// Throws std::invalid_argument for bad parameters or images.
DisparityResult ComputeDisparity(const cv::Mat& left_gray8, const cv::Mat& right_gray8, const DisparityParams& params,
                                 const RoadModel* prior = nullptr);

/// Sub-pixel disparity from the intensities instead of SGM's cost curve: winner-takes-all plus an
/// equiangular fit on aggregated costs pulls towards integers (pixel locking, up to ~0.15 px bias
/// where the road's residual lies half-way between integers, i.e. wherever the road model is off).
/// Both images are high-passed (minus a local mean, SubpixelRefineOptions::highpass: gain and
/// vignetting differ between the cameras). For each valid pixel n with SGM's integer winner
/// k_n = round(l_n), e_n = ref(u) - target(u - k_n) and the derivative G_n there (mean of both views' 5-tap
/// differences) give the linearised estimate k_n - e_n / G_n (pixels whose step exceeds 1 px are left out); a pixel's
/// refined value is the average of these over its window x window neighbourhood weighted by
/// G_n^2 (the window's least-squares shift, 1-D Lucas-Kanade, one Gauss-Newton step from exact
/// integer samples). A pixel keeps its input value when the window's mean squared slope is below
/// 4 (grey levels/px)^2 (no texture: inside painted lines) or the result moves it by more than 1 px. `disparity`:
/// CV_32F, match at column u - l in `target` (the images SGM compared); invalid pixels are left alone. window 0 =
/// no-op.
void RefineSubpixel(const cv::Mat& ref, const cv::Mat& target, cv::Mat* disparity, const cv::Mat& valid, int window);

/// RefineSubpixel's options beyond the window.
struct SubpixelRefineOptions {
  int window = 9;  ///< the refinement window, odd; 0 = no-op
  /// Larger window (odd; <= window = off): a second refinement from the input values (noise falls
  /// with the window's area), taken where it agrees with the first within smooth_agree_px (widened
  /// to ~5 standard deviations of the first's estimate where its texture is weak) and the first's
  /// value is at most smooth_max_px. Gated on its own precision (sum G^2), not on the first's
  /// texture gate.
  int smooth_window = 0;
  double smooth_agree_px = 0.2;
  double smooth_max_px = 1e30;
  /// With smooth_window: pixels whose window is dominated by one straight, mostly vertical edge of
  /// `ref` (structure-tensor coherence (l1 - l2) / (l1 + l2) above this, sum gx^2 >= 2 sum gy^2)
  /// give no terms to the smooth window and take its value; >= 1 = off.
  double max_edge_coherence = 1.0;
  /// Box of the local mean subtracted from both images before the least squares (odd, >= 3;
  /// DisparityParams::refine_highpass_px).
  int highpass = 9;
  /// With smooth_window: shiftable smooth windows (DisparityParams::refine_shift_ratio); 0 = off, else >= 1.
  double shift_ratio = 0;
  /// The window's height per image row (odd, 1..window; GroundWindowRows); empty = square. Each
  /// band of rows the refinement runs on takes its middle row's.
  std::vector<int> window_rows;
};

/// RefineSubpixel with the larger smooth window and the edge test. `window_value` (optional): the
/// refine_window pass's value alone, before the smooth window's is taken (a copy of the result
/// where no smooth window runs): it keeps a pothole's wall where the smooth window spreads it.
void RefineSubpixel(const cv::Mat& ref, const cv::Mat& target, cv::Mat* disparity, const cv::Mat& valid,
                    const SubpixelRefineOptions& options, cv::Mat* window_value = nullptr);

/// Per image row, the height (odd, in [min(5, window), window]) of a window `window` px wide that
/// covers a square on the road plane `road` (d = road disparity): a ground square at depression
/// angle a appears sin a as tall as wide, and sin a = h/Z (Z: its depth, h: the camera's height)
/// = d(row) / (f·B/h), with f·B/h = sqrt(d0^2 + f^2 |grad d|^2) (d0 at the image centre, the
/// gradient the plane's) since the road's unit normal n gives d = (f·B/h)(n . ray). Rows above
/// the horizon (d <= 0) and nadir views (ratio >= 1) keep `window`.
std::vector<int> GroundWindowRows(const RoadModel& road, int width, int height, double focal_px, int window);

/// Drops 4-connected regions of valid pixels (neighbour steps <= max_diff_px) with fewer than
/// max_size pixels; sets their disparity to 0 and validity to 0.
void FilterSpeckles(cv::Mat* disparity, cv::Mat* valid, int max_size, double max_diff_px);

/// 3x3 median over valid neighbours of each valid pixel (lower median for even counts).
void MedianValid3x3(cv::Mat* disparity, const cv::Mat& valid);

/// Fills each invalid pixel (not on the image border) whose 8 neighbours include at least
/// min_neighbours valid ones spanning at most max_spread_px with their lower median, and marks it
/// valid. Decisions use the input only (filled pixels do not feed other fills). Returns the count.
int64_t FillSmallHoles(cv::Mat* disparity, cv::Mat* valid, int min_neighbours, double max_spread_px);

}  // namespace rs
