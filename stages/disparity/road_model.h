#pragma once
// Road disparity model d = a0 + a1 * (v cos(phi) - u sin(phi)) fitted to sparse stereo
// matches (MISSION eq. 3), with an optional quadratic surface for cambered roads.

#include <array>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace rs {

/// Fitted road disparity surface in the rectified left image (u column, v row, px).
struct RoadModel {
  double a0 = 0, a1 = 0;  ///< planar model parameters, px and px/px
  double roll_rad = 0;    ///< stereo-rig roll angle phi, in (-pi/2, pi/2]
  /// The surface actually evaluated: d = c0 + c1 u + c2 v + c3 u^2 + c4 uv + c5 v^2. For the
  /// planar model c = (a0, -a1 sin(phi), a1 cos(phi), 0, 0, 0); set it through SetRoll/SetPlane.
  std::array<double, 6> c{};
  bool quadratic = false;      ///< c3..c5 in use (cambered road refinement)
  int num_matches = 0;         ///< sparse matches that entered the fit
  int num_inliers = 0;         ///< matches within the inlier threshold of the final model
  double residual_rms_px = 0;  ///< RMS residual of the inliers, px
  bool reliable = false;       ///< enough inliers; false = callers fall back to plain SGM
  bool from_prior = false;     ///< the prior model won the robust fit (no better hypothesis)

  /// Road disparity at (u, v), px.
  double At(double u, double v) const;
  /// min over x in [0, width) of At(x, v): the per-row minimum used by the GPT shift.
  double RowMin(double v, int width) const;
  /// Sets the planar model from (a0, a1, phi).
  void SetRoll(double a0_px, double a1_px, double roll);
  /// Sets (a0, a1, roll) from a plane d = c0 + cu u + cv v (the two are the same family).
  void SetPlane(double c0, double cu, double cv);
};

/// A sparse disparity sample d at (u, v).
struct DisparitySample {
  double u = 0, v = 0, d = 0;
};

/// Options of the sparse matching and robust fit.
struct RoadFitOptions {
  int max_features = 1500;        ///< strongest FAST corners kept per image (ORB descriptors)
  int fast_threshold = 12;        ///< FAST corner threshold, grey levels
  double detect_scale = 0.5;      ///< detect and match on images resized by this (0, 1]; refined at full size
  double max_row_diff_px = 1.0;   ///< epipolar constraint |v_left - v_right| <= this
  double min_disparity_px = 0.5;  ///< matches need d > this (positive disparity)
  /// and d <= this; 0 = the whole common field of view, d < image width (a rectified pair's views
  /// overlap from depth f·B/W on, so no nearer point can be matched)
  double max_disparity_px = 0;
  double ratio = 0.8;             ///< Lowe ratio test on Hamming distances among epipolar candidates
  int max_hamming = 64;           ///< descriptor distance ceiling (of 256 bits)
  /// Most planar hypotheses drawn; RANSAC stops earlier (after at least 50) once the best inlier
  /// share makes an all-inlier sample 99.99 % likely.
  int ransac_iterations = 400;
  double inlier_threshold_px = 1.5;  ///< |d - model| for an inlier
  int min_inliers = 40;              ///< fewer inliers: model marked unreliable
  /// Smaller inlier share of the matches: unreliable (the scene is not dominated by a road plane).
  double min_inlier_fraction = 0.5;
  double max_residual_rms_px = 1.0;  ///< larger inlier RMS: unreliable
  bool quadratic = false;            ///< refine with the quadratic surface (cambered roads)
  unsigned seed = 1;                 ///< RANSAC random seed (deterministic runs)

  /// Throws std::invalid_argument naming the rule broken.
  void Check() const;
};

/// Sparse disparities from FAST + ORB matches between rectified grey images: epipolar
/// (row) constraint, positive disparity, ratio test and left-right cross check, on images
/// resized by detect_scale (speed); each match is then re-located at full size by the 7x7 SAD
/// minimum near the scaled disparity and refined to sub-pixel by a parabola through it.
std::vector<DisparitySample> MatchSparseDisparities(const cv::Mat& left_gray8, const cv::Mat& right_gray8,
                                                    const RoadFitOptions& options);

/// Disparity range [min, min + num) that holds the matches: their 1st to 99th percentile widened by
/// 10 % of that span plus margin_px on each side, clamped to [0, width). Matches cover the textured part
/// of a scene, not always its nearest or farthest points, hence the widening. Returns num = 0 when
/// fewer than min_matches samples are given (too few for percentiles to mean anything).
struct DisparityRange {
  int min = 0, num = 0;
};
DisparityRange DisparityRangeOfMatches(const std::vector<DisparitySample>& samples, int width, double margin_px,
                                       int min_matches);

/// Lateral tilt of the road plane against the camera's image rows, rad: asin of the road normal's
/// component along the camera x axis. With d = (B/h) n . (u - cx, v - cy, f) for a plane at distance h
/// with unit normal n, n is parallel to (f c_u, f c_v, d(cx, cy)). For a forward view it equals the roll
/// phi; unlike phi it stays defined for a nadir view (where phi is the direction of a tiny gradient).
/// Planar part of the model; (cx, cy): principal point, px.
double RoadLateralTiltRad(const RoadModel& road, double focal_px, double cx_px, double cy_px);

/// Robust fit (RANSAC on planes, then least squares on inliers, then optional quadratic
/// refinement). A prior model (e.g. the previous frame's) is scored as the first hypothesis.
RoadModel FitRoadModel(const std::vector<DisparitySample>& samples, int image_width, int image_height,
                       const RoadFitOptions& options, const RoadModel* prior = nullptr);

/// Least-squares roll angle and (a0, a1) over all samples, by the authors' closed form
/// (stationary points of E(a, phi) in phi); equals the plane fit, kept as a cross-check.
RoadModel FitRoadModelClosedForm(const std::vector<DisparitySample>& samples);

}  // namespace rs
