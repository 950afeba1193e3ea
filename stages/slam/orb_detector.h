#pragma once
// cv::ORB's keypoint detection (HARRIS_SCORE, firstLevel 0) with a vectorised FAST.

#include <vector>

#include <opencv2/core.hpp>

namespace rs {

/// The keypoints of cv::ORB::create(nfeatures, scale_factor, nlevels, edge_threshold, 0, 2, HARRIS_SCORE,
/// patch_size, fast_threshold)->detect(gray, out), bit for bit and in the same order (OpenCV 4.6).
/// `gray` is CV_8UC1; edge_threshold must exceed the patch radius (+1 for row padding) and 4 (ExtractOrb: 19, 31).
void DetectOrbCorners(const cv::Mat& gray, int nfeatures, float scale_factor, int nlevels, int edge_threshold,
                      int patch_size, int fast_threshold, std::vector<cv::KeyPoint>* out);

}  // namespace rs
