#include "stages/damage/road/grid_fill.h"

#include <cmath>
#include <vector>

namespace rs {

void FillEmptyCellsFromNeighbours(cv::Mat* grid) {
  const int gh = grid->rows, gw = grid->cols;
  for (int pass = 0; pass < gw + gh; ++pass) {
    cv::Mat next = grid->clone();
    bool missing = false, any = false;
    for (int y = 0; y < gh; ++y)
      for (int x = 0; x < gw; ++x) {
        if (std::isfinite(grid->at<float>(y, x))) {
          any = true;
          continue;
        }
        double sum = 0;
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int yy = y + dy, xx = x + dx;
            if (yy < 0 || xx < 0 || yy >= gh || xx >= gw) continue;
            const float q = grid->at<float>(yy, xx);
            if (std::isfinite(q)) sum += q, ++n;
          }
        if (n)
          next.at<float>(y, x) = static_cast<float>(sum / n);
        else
          missing = true;
      }
    *grid = next;
    if (!missing || !any) break;
  }
}

cv::Mat LabelSmoothRegions(const cv::Mat& grid, float max_step, int* count) {
  cv::Mat labels = cv::Mat::zeros(grid.size(), CV_32S);
  int n = 0;
  std::vector<cv::Point> stack;
  const auto inside = [&](cv::Point q) { return q.x >= 0 && q.y >= 0 && q.x < grid.cols && q.y < grid.rows; };
  for (int y0 = 0; y0 < grid.rows; ++y0)
    for (int x0 = 0; x0 < grid.cols; ++x0) {
      if (labels.at<int>(y0, x0) || !std::isfinite(grid.at<float>(y0, x0))) continue;
      labels.at<int>(y0, x0) = ++n;
      stack.assign(1, {x0, y0});
      while (!stack.empty()) {  // flood fill
        const cv::Point p = stack.back();
        stack.pop_back();
        const float a = grid.at<float>(p);
        for (const cv::Point d : {cv::Point(-1, 0), cv::Point(1, 0), cv::Point(0, -1), cv::Point(0, 1)}) {
          const cv::Point q = p + d;
          if (!inside(q) || labels.at<int>(q)) continue;
          const float b = grid.at<float>(q);
          if (!std::isfinite(b) || !(std::abs(b - a) < max_step)) continue;
          // A step spread over two cells (a sample on the step's face) also cuts the link. (The
          // cells right beside a step may so form a thin region of their own.)
          if (inside(q + d) && std::abs(grid.at<float>(q + d) - a) >= max_step) continue;
          if (inside(p - d) && std::abs(b - grid.at<float>(p - d)) >= max_step) continue;
          labels.at<int>(q) = n;
          stack.push_back(q);
        }
      }
    }
  if (count) *count = n;
  return labels;
}

}  // namespace rs
