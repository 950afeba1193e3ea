#include "stages/damage/noise/image_edges.h"

#include <opencv2/imgproc.hpp>

#include <stdexcept>

namespace rs {

cv::Mat StrongEdgeMask(const cv::Mat& image, double min_gradient, int margin_px) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw std::invalid_argument("StrongEdgeMask: image must be 8-bit grey or BGR");
  if (!(min_gradient > 0) || margin_px < 0)
    throw std::invalid_argument("StrongEdgeMask: min_gradient > 0 and margin_px >= 0 needed");
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  // Half resolution: σ = 3 px there is 1.5 px, a quarter of the work; the mask needs no pixel accuracy.
  cv::Mat small, gx, gy, mag;
  cv::resize(grey, small, cv::Size((grey.cols + 1) / 2, (grey.rows + 1) / 2), 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(small, small, {0, 0}, 1.5);
  // Sobel / 8 = grey levels per (half-resolution) pixel; / 2 more per full-resolution pixel.
  cv::Sobel(small, gx, CV_32F, 1, 0, 3, 1.0 / 16.0);
  cv::Sobel(small, gy, CV_32F, 0, 1, 3, 1.0 / 16.0);
  cv::magnitude(gx, gy, mag);
  cv::Mat edge = mag >= min_gradient;
  const int r = (margin_px + 1) / 2;
  if (r > 0) cv::dilate(edge, edge, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
  cv::Mat full;
  cv::resize(edge, full, grey.size(), 0, 0, cv::INTER_NEAREST);
  return full;
}

}  // namespace rs
