#include "stages/damage/grid_fill.h"

#include <cmath>

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
        if (n) next.at<float>(y, x) = static_cast<float>(sum / n);
        else missing = true;
      }
    *grid = next;
    if (!missing || !any) break;
  }
}

}  // namespace rs
