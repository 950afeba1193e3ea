#pragma once
// Where the left image makes the disparity unreliable for shallow damage: strong, extended
// intensity steps such as the edges of lane markings. There the census window straddles
// uniform paint and textured asphalt, and the matcher's error (0.3–1 px, 20–60 mm at 4–6 m)
// exceeds a shallow pothole's depth; the resulting false depressions follow the paint's
// outline. Asphalt texture and a pothole's shaded rim are much weaker once blurred.

#include <opencv2/core.hpp>

namespace rs {

/// CV_8U mask (255) of pixels within `margin_px` of a strong step edge: the gradient magnitude
/// of the image blurred with σ = 3 px (computed at half resolution) is at least
/// `min_gradient` grey levels per pixel. 8-bit grey or BGR input.
/// Throws std::invalid_argument on other images or min_gradient ≤ 0, margin_px < 0.
cv::Mat StrongEdgeMask(const cv::Mat& image, double min_gradient, int margin_px);

}  // namespace rs
