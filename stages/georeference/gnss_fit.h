#pragma once
// The similarity that carries a SLAM trajectory onto GNSS antenna positions:
// b_i ~ s R a_i + t, with a_i the antenna in the SLAM world and b_i the GNSS fix in a local ENU
// frame. Robust: RANSAC over 3-point Umeyama fits, then iteratively reweighted Umeyama with Huber
// weights. SE(3) (s = 1, the stereo rig's metric scale) or Sim(3).
//
// Rotation about the track's main direction (roll of a straight track) is not observable from
// positions; RollAboutTrackAxis() fixes it from directions known to be up (gravity from the
// flight log's attitude, or road-plane normals), weighed against what the positions tell.

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

namespace rs {

/// How the similarity is fitted.
struct GnssFitOptions {
  bool estimate_scale = false;   ///< Sim(3) instead of SE(3)
  double sigma_m = 1.0;          ///< expected GNSS position error (1 sigma, per axis) before any fit, m
  double outlier_sigmas = 3.0;   ///< a fix further than this many sigmas on any axis is an outlier
  double huber_k = 1.345;        ///< Huber threshold in robust sigmas (95% efficiency on Gaussian errors)
  int ransac_iterations = 200;   ///< 3-point hypotheses
  int irls_iterations = 10;      ///< reweighted Umeyama rounds
  uint64_t seed = 1;             ///< RANSAC sampling seed (same input and seed, same result)
};

/// A similarity transform p_enu = scale * R * p_slam + t.
struct Similarity3 {
  double scale = 1;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector3d Apply(const Eigen::Vector3d& p) const { return scale * (R * p) + t; }
};

/// The fit and what it knows about itself.
struct GnssFit {
  Similarity3 transform;
  std::vector<bool> inlier;        ///< per sample: kept by RANSAC and the final outlier test
  std::vector<double> weight;      ///< final Huber weight per sample (0 for outliers)
  Eigen::Vector3d sigma_axis_m = Eigen::Vector3d::Zero();  ///< robust residual sigma per ENU axis (1.4826 MAD), m
  double sigma_m = 0;              ///< RMS of the three axis sigmas, m
  double scale_sigma = 0;          ///< 1-sigma of the scale (Sim(3); 0 for SE(3))
  Eigen::Vector3d axis_slam = Eigen::Vector3d::UnitX();  ///< the track's main direction, SLAM world
  /// Information (1/rad^2) the positions carry about the rotation about axis_slam: sum of squared
  /// distances from the axis over sigma^2. Near zero on a straight track.
  double roll_information = 0;
  int ransac_inliers = 0;
};

/// Throws std::invalid_argument for fewer than 3 samples or mismatched sizes.
GnssFit FitSlamToGnss(const std::vector<Eigen::Vector3d>& a_slam, const std::vector<Eigen::Vector3d>& b_enu,
                      const GnssFitOptions& options);

/// Weighted Umeyama: minimises sum w_i |b_i - (s R a_i + t)|^2; s = 1 unless `with_scale`.
Similarity3 WeightedUmeyama(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                            const std::vector<double>& w, bool with_scale);

/// The rotation about the track axis that up-directions ask for.
struct RollEstimate {
  int observations = 0;
  double angle_rad = 0;     ///< rotation about the ENU track axis that makes the up-directions vertical
  double sigma_rad = 0;     ///< its 1-sigma, from the scatter of per-observation angles
  double weight = 0;        ///< share given to it against the positions (inverse-variance)
  double applied_rad = 0;   ///< weight * angle_rad: the rotation applied
};

/// `up_slam`: directions in the SLAM world that are (near) vertical-up in ENU. Estimates the
/// rotation about the fitted track axis that best makes them vertical (closed form, any angle),
/// combines it with the positions' own information (fit.roll_information) by inverse variance
/// and applies it to fit.transform, keeping the weighted centroid fixed. `a_slam` are the fit's samples.
RollEstimate RollAboutTrackAxis(const std::vector<Eigen::Vector3d>& up_slam, const std::vector<Eigen::Vector3d>& a_slam,
                                GnssFit& fit);

}  // namespace rs
