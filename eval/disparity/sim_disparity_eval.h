#pragma once
// Disparity truth regions of a `roadsurvey simulate` folder (docs/simulator.md): the frames as
// StereoPairWithTruth with a road mask and a pothole mask, so the benchmark scores ours and
// StereoSGBM on exactly the pixels the accuracy targets name. Protocol: docs/results/disparity.md
// ("Simulated surveys: GPT-SGM against StereoSGBM").
//
// Regions (left view, all need a truth disparity):
//   visible  the truth point is inside the right image (0 <= u - d <= W - 1) and not occluded there:
//            no pixel further right in the row maps left of it (u' - d(u') < u - d(u) - 0.5 px);
//   road     visible, on the intact carriageway (|l| <= road_width / 2 - road_edge_margin_m in
//            the simulator's road coordinates, from the truth pose and scene.json), within
//            surface_tolerance_m of the intact surface height (so obstacles are not road), and no
//            damage (truth mask 0);
//   pothole  visible and in the truth mask of a damage whose type is "pothole" (damages.geojson).

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "eval/disparity/disparity_eval.h"

namespace rs {

/// Which frames to load and how the road region is cut.
struct SimulatedPairOptions {
  int first_frame = 0;  ///< index of the first frame (sorted file names of left/)
  int frame_step = 1;   ///< every n-th frame from first_frame
  int max_frames = 0;   ///< at most this many frames (0 = all)
  /// Pixels nearer the kerb line than this are not road (the 1 cm kerb ramp, lane edge), m.
  double road_edge_margin_m = 0.05;
  /// Largest |height - intact road height| of a road pixel, m; the truth disparity's 1/256 px
  /// quantisation is added (Z^2 / (f B) / 512) so far pixels of forward views stay in.
  double surface_tolerance_m = 0.02;
};

/// Left-view visibility from the left truth alone (see the header comment). CV_8U 255/0.
cv::Mat VisibleInRightView(const cv::Mat& gt_left, double tolerance_px = 0.5);

/// Loads the chosen frames of the simulated survey `dir` (rectified; truth/disparity present):
/// left/right images, truth disparity, `nonocc` = visible, `road`, `pothole`; plain-SGM range
/// [0, max truth + 8) rounded up to 16. Names "<dir name>/<frame>".
/// Throws InputError naming the file when something is missing or malformed.
std::vector<StereoPairWithTruth> LoadSimulatedSurvey(const std::filesystem::path& dir,
                                                     const SimulatedPairOptions& options = {});

/// Signed disparity error distribution (estimate - truth) over a simulated pair's road and pothole
/// regions. D1 (3 px) hides what matters downstream: at 6 m a 0.3 px error is already ~4 cm of
/// depth, so the shares of road pixels beyond 0.25 and 0.5 px are what the damage stage feels.
/// Additive over pairs (Add); ratios from the accessors.
struct RoadErrorStats {
  static constexpr int kBins = 40;                               ///< signed-error histogram: 0.05 px bins over [-1, 1)
  int64_t road = 0, road_valid = 0;                              ///< road pixels with truth; with a valid estimate
  int64_t road_over_025 = 0, road_over_05 = 0, road_over_1 = 0;  ///< valid road pixels with |err| > 0.25, 0.5, 1 px
  double road_abs_sum = 0, road_signed_sum = 0;  ///< sums of |err| and err over valid road pixels with |err| <= 3 px
  int64_t road_within_3 = 0;                     ///< valid road pixels with |err| <= 3 px (the signed mean's count)
  /// Valid road pixels by signed error: [0] below -1 px, [1 + b] in [-1 + 0.05 b, -0.95 + 0.05 b),
  /// [kBins + 1] at or above 1 px.
  std::array<int64_t, kBins + 2> histogram{};
  /// Valid road pixels with |err| > 0.25 px and all valid road pixels in the left, middle and
  /// right third of the image columns (camber shows in the outer thirds).
  std::array<int64_t, 3> third_over_025{}, third_valid{};
  int64_t pothole = 0, pothole_valid = 0;  ///< pothole pixels with truth; with a valid estimate
  double pothole_abs_sum = 0;              ///< sum of |err| over valid pothole pixels

  void Add(const RoadErrorStats& other);
  double RoadDensity() const { return road ? double(road_valid) / double(road) : 0; }
  double RoadEpe() const;                           ///< mean |err| over all valid road pixels, px
  double RoadSignedMean() const;                    ///< mean err over valid road pixels with |err| <= 3 px, px
  double RoadShareOver(double threshold_px) const;  ///< 0.25, 0.5 or 1: share of valid road pixels
  double PotholeMae() const { return pothole_valid ? pothole_abs_sum / double(pothole_valid) : 0; }
  /// Signed-error quantile q in (0, 1) from the histogram (linear inside a bin; clamped to [-1, 1]), px.
  double RoadQuantile(double q) const;
  /// One line: density, EPE, signed mean, shares > 0.25 / 0.5 / 1 px, signed 5/50/95 % quantiles,
  /// share > 0.25 px per column third, pothole MAE.
  std::string Format() const;
};

/// Road error of a band of image rows: on a forward view (the `car` preset) a row band is a range
/// bin. Besides EPE and bias, the row-to-row wobble of the error ("stripe"): each row's mean signed
/// error (rows with >= kMinRowPixels valid road pixels, |err| <= 1 px) minus the mean of the rows
/// within +-kStripeHalf, RMS over the band's rows — what a damage stage fitting the road over a
/// few rows sees as horizontal stripes. Additive over pairs (Add).
struct RoadBandStats {
  static constexpr int kMinRowPixels = 30, kStripeHalf = 4;
  int row_begin = 0, row_end = 0;                  ///< rows [row_begin, row_end)
  int64_t road = 0, valid = 0;                     ///< road pixels with truth; with a valid estimate
  int64_t within_1 = 0;                            ///< valid road pixels with |err| <= 1 px
  double abs_sum = 0, signed_sum = 0, gt_sum = 0;  ///< over the within_1 pixels
  double stripe_sq_sum = 0;                        ///< sum over rows of the squared row-mean deviation
  int64_t stripe_rows = 0;                         ///< rows in stripe_sq_sum

  void Add(const RoadBandStats& other);
  double Epe() const { return within_1 ? abs_sum / double(within_1) : 0; }  ///< mean |err| (|err| <= 1), px
  double SignedMean() const { return within_1 ? signed_sum / double(within_1) : 0; }
  double MeanTruth() const { return within_1 ? gt_sum / double(within_1) : 0; }  ///< mean truth disparity, px
  double StripeRms() const { return stripe_rows ? std::sqrt(stripe_sq_sum / double(stripe_rows)) : 0; }
};

/// RoadBandStats of `disparity` over p.road for the row bands [edges[i], edges[i + 1]).
std::vector<RoadBandStats> MeasureRoadErrorsByRows(const StereoPairWithTruth& p, const cv::Mat& disparity,
                                                   const cv::Mat& valid, const std::vector<int>& edges);

/// Error statistics of `disparity` (CV_32F, valid where `valid` != 0) against p.gt over p.road and
/// p.pothole.
RoadErrorStats MeasureRoadErrors(const StereoPairWithTruth& p, const cv::Mat& disparity, const cv::Mat& valid);

}  // namespace rs
