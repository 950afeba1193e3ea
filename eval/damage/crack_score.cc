#include "eval/damage/crack_score.h"

#include <opencv2/imgproc.hpp>

#include <stdexcept>

namespace rs {

double TolerantPixelScore::Precision() const {
  if (predicted == 0) return truth == 0 ? 1.0 : 0.0;
  return double(predicted_near) / double(predicted);
}

double TolerantPixelScore::Recall() const { return truth == 0 ? 1.0 : double(truth_near) / double(truth); }

double TolerantPixelScore::F1() const {
  const double p = Precision(), r = Recall();
  return p + r > 0 ? 2 * p * r / (p + r) : 0.0;
}

TolerantPixelScore& TolerantPixelScore::operator+=(const TolerantPixelScore& o) {
  predicted += o.predicted, predicted_near += o.predicted_near, truth += o.truth, truth_near += o.truth_near;
  return *this;
}

namespace {

// Pixels of `from` (non-zero) whose Euclidean distance to the nearest non-zero pixel of `to`
// is at most `tolerance`; none when `to` is empty.
long long NearCount(const cv::Mat& from, const cv::Mat& to, double tolerance) {
  if (cv::countNonZero(to) == 0) return 0;
  cv::Mat dist;  // distance of every pixel to the nearest pixel of `to` (exact Euclidean)
  cv::distanceTransform(to == 0, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  // A tiny slack: the transform is float, the tolerance an exact distance such as √8.
  return cv::countNonZero((dist <= tolerance + 1e-4) & (from != 0));
}

}  // namespace

TolerantPixelScore ScoreCrackPixels(const cv::Mat& predicted, const cv::Mat& truth, double tolerance_px) {
  if (predicted.size() != truth.size() || predicted.channels() != 1 || truth.channels() != 1)
    throw std::invalid_argument("ScoreCrackPixels: masks must be single-channel and of equal size");
  if (!(tolerance_px >= 0)) throw std::invalid_argument("ScoreCrackPixels: tolerance must be >= 0");
  TolerantPixelScore s;
  s.predicted = cv::countNonZero(predicted);
  s.truth = cv::countNonZero(truth);
  s.predicted_near = NearCount(predicted, truth, tolerance_px);
  s.truth_near = NearCount(truth, predicted, tolerance_px);
  return s;
}

}  // namespace rs
