#include "stages/surface/hole_fill.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace rs {
namespace {

// Fills the `fill` cells of a CV_32F image from the outside in: each round, every cell with known
// 8-neighbours takes their mean and becomes known (a harmonic-like interpolation from the rim).
// `empty`: cells without a value (never read); only `fill` cells are written.
void PeelFill(const cv::Mat& fill, const cv::Mat& empty, cv::Mat* z) {
  cv::Mat known = ~empty;
  for (bool changed = true; changed;) {
    changed = false;
    cv::Mat next = known.clone();
    for (int r = 0; r < z->rows; ++r)
      for (int c = 0; c < z->cols; ++c) {
        if (known.at<uint8_t>(r, c) || !fill.at<uint8_t>(r, c)) continue;
        double sum = 0;
        int n = 0;
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            const int rr = r + dr, cc = c + dc;
            if (rr < 0 || cc < 0 || rr >= z->rows || cc >= z->cols || !known.at<uint8_t>(rr, cc)) continue;
            sum += z->at<float>(rr, cc), ++n;
          }
        if (n == 0) continue;
        z->at<float>(r, c) = static_cast<float>(sum / n);
        next.at<uint8_t>(r, c) = 255;
        changed = true;
      }
    known = next;
  }
}

}  // namespace

int FillSmallHoles(FusedTile* t, double max_width_cells) {
  const cv::Mat empty = t->count == 0;
  if (cv::countNonZero(empty) == 0 || cv::countNonZero(empty) == empty.total()) return 0;
  cv::Mat dist, labels;
  cv::distanceTransform(empty, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const int n = cv::connectedComponents(empty, labels, 8, CV_32S);
  std::vector<float> width(n, 0);
  std::vector<char> at_edge(n, 0);
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c) {
      const int l = labels.at<int>(r, c);
      if (l == 0) continue;
      width[l] = std::max(width[l], 2 * dist.at<float>(r, c));
      if (r == 0 || c == 0 || r + 1 == labels.rows || c + 1 == labels.cols) at_edge[l] = 1;
    }
  cv::Mat fill(empty.size(), CV_8U, cv::Scalar(0));
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c) {
      const int l = labels.at<int>(r, c);
      if (l > 0 && !at_edge[l] && width[l] <= max_width_cells) fill.at<uint8_t>(r, c) = 255;
    }
  const int filled = cv::countNonZero(fill);
  if (filled == 0) return 0;
  PeelFill(fill, empty, &t->height_m);
  cv::Mat colour;
  cv::inpaint(t->colour, fill, colour, 3, cv::INPAINT_TELEA);
  colour.copyTo(t->colour, fill);
  // Each hole's σ: its rim's largest σ plus the rim's height spread (what the interpolation cannot
  // know about the floor it bridges).
  cv::Mat hole_labels, stats, centroids;
  const int holes = cv::connectedComponentsWithStats(fill, hole_labels, stats, centroids, 8, CV_32S);
  for (int i = 1; i < holes; ++i) {
    const cv::Rect box = cv::Rect(stats.at<int>(i, cv::CC_STAT_LEFT) - 1, stats.at<int>(i, cv::CC_STAT_TOP) - 1,
                                  stats.at<int>(i, cv::CC_STAT_WIDTH) + 2, stats.at<int>(i, cv::CC_STAT_HEIGHT) + 2) &
                         cv::Rect(0, 0, fill.cols, fill.rows);
    const cv::Mat hole = hole_labels(box) == i;
    cv::Mat rim;
    cv::dilate(hole, rim, cv::Mat());
    rim &= ~empty(box);
    double h_min = 0, h_max = 0, s_max = 0;
    cv::minMaxLoc(t->height_m(box), &h_min, &h_max, nullptr, nullptr, rim);
    cv::minMaxLoc(t->sigma_m(box), nullptr, &s_max, nullptr, nullptr, rim);
    t->sigma_m(box).setTo(static_cast<float>(s_max + (h_max - h_min)), hole);
  }
  return filled;
}

}  // namespace rs
