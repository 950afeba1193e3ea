#pragma once
// Crack pixels scored with a distance tolerance: a thin structure drawn or detected a pixel or
// two off its true place still counts (the usual convention of crack benchmarks).

#include <opencv2/core.hpp>

namespace rs {

/// Pixel counts of one or more images; ratios follow from the pooled counts.
struct TolerantPixelScore {
  long long predicted = 0;       ///< predicted crack pixels
  long long predicted_near = 0;  ///< of them, within the tolerance of a true crack pixel
  long long truth = 0;           ///< true crack pixels
  long long truth_near = 0;      ///< of them, within the tolerance of a predicted crack pixel
  /// predicted_near / predicted; 1 without predictions and without truth, 0 with truth only.
  double Precision() const;
  /// truth_near / truth; 1 without truth.
  double Recall() const;
  /// Harmonic mean of Precision() and Recall(); 0 when both are 0.
  double F1() const;
  TolerantPixelScore& operator+=(const TolerantPixelScore& other);
};

/// Scores `predicted` against `truth` (single-channel masks of equal size, non-zero = crack):
/// a pixel is near when its Euclidean distance to the nearest pixel of the other mask is at
/// most `tolerance_px` (0 = exact overlap). Throws std::invalid_argument on size or channel
/// mismatch or a negative tolerance.
TolerantPixelScore ScoreCrackPixels(const cv::Mat& predicted, const cv::Mat& truth, double tolerance_px);

}  // namespace rs
