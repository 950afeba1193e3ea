#pragma once
// Front end of the SLAM: ORB features (FAST corners on a scale pyramid, rotated BRIEF
// descriptors) spread over the image by a grid, then matched along rectified rows of the
// right image with sub-pixel (SAD + parabola) refinement, giving a depth per feature.

#include <bit>
#include <cstdint>
#include <cstring>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "formats/rectified_stereo.h"
#include "stages/slam/slam_options.h"

namespace rs {

/// Scale of each pyramid level and the reprojection variance (1 px sigma at level 0).
struct ScalePyramid {
  std::vector<double> scale, sigma2, inv_sigma2;
  ScalePyramid() = default;
  ScalePyramid(int levels, double factor);
  int levels() const { return static_cast<int>(scale.size()); }
  /// Level at which a point at `distance_m` is expected, given it was seen at `ref_distance_m` on `ref_level`.
  int PredictLevel(double distance_m, double max_distance_m) const;
};

/// The features of one stereo pair, indexed alike.
struct StereoFeatures {
  std::vector<cv::KeyPoint> keypoints;  ///< left image, level-0 pixel coordinates, octave = pyramid level
  cv::Mat descriptors;                  ///< N x 32 CV_8U ORB descriptors
  std::vector<float> u_right;           ///< matched x in the right image, px; -1 when unmatched
  std::vector<float> depth_m;           ///< depth from the stereo match, m; -1 when unmatched
  size_t size() const { return keypoints.size(); }
  /// Indices of features inside the circle (u, v, radius) on levels [min_level, max_level] (-1: any).
  std::vector<int> FeaturesInArea(double u, double v, double radius, int min_level, int max_level) const;
  /// Builds the spatial grid FeaturesInArea uses; called by ExtractStereoFeatures.
  void BuildGrid(int width, int height);

  int grid_cols = 0, grid_rows = 0;
  static constexpr double kGridCellPx = 16;
  std::vector<std::vector<int>> grid;
};

/// ORB features of an 8-bit grey image spread over a grid: at most `max_features`, at most an equal
/// share per cell first, the strongest remaining ones filling up. Deterministic.
void ExtractOrb(const cv::Mat& gray, const SlamOptions& options, std::vector<cv::KeyPoint>* keypoints,
                cv::Mat* descriptors);

/// ORB keypoints (level-0 coordinates) and descriptors of one image, as ExtractOrb gives them.
struct OrbFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

/// Stereo matching of a rectified pair's ORB features (the second half of ExtractStereoFeatures):
/// row-band descriptor match, SAD + parabola sub-pixel disparity, depth.
StereoFeatures MatchStereo(const cv::Mat& left, const cv::Mat& right, OrbFeatures left_features,
                           const OrbFeatures& right_features, const RectifiedStereo& camera, const SlamOptions& options,
                           const ScalePyramid& pyramid);

/// Features of a rectified pair with stereo depths. Left and right extraction run concurrently when
/// options.parallel (the result does not depend on it).
StereoFeatures ExtractStereoFeatures(const cv::Mat& left, const cv::Mat& right, const RectifiedStereo& camera,
                                     const SlamOptions& options, const ScalePyramid& pyramid);

/// Hamming distance of two 32-byte ORB descriptors (inline: the matchers' innermost loops call it).
inline int DescriptorDistance(const uint8_t* a, const uint8_t* b) {
  int d = 0;
  for (int i = 0; i < 32; i += 8) {
    uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    d += std::popcount(x ^ y);
  }
  return d;
}

}  // namespace rs
