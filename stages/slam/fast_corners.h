#pragma once
// FAST-9/16 corners with non-maximum suppression, vectorised with Highway (run-time dispatch).

#include <vector>

#include <opencv2/core.hpp>

namespace rs {

/// The same keypoints as cv::FAST(gray8u, out, threshold, true, cv::FastFeatureDetector::TYPE_9_16), in the
/// same order with the same fields: corners on rows and columns [3, n-4], score as OpenCV's cornerScore<16>.
/// `gray8u` is CV_8UC1 (any step); `threshold` in [0, 255], else std::invalid_argument.
void DetectFastCorners(const cv::Mat& gray8u, int threshold, std::vector<cv::KeyPoint>* out);

}  // namespace rs
