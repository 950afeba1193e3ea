#include "stages/damage/segment/rect_merge.h"

namespace rs {

void MergeOverlappingRects(std::vector<cv::Rect>* rects) {
  std::vector<cv::Rect>& r = *rects;
  for (bool merged = true; merged;) {
    merged = false;
    for (size_t i = 0; i < r.size() && !merged; ++i)
      for (size_t j = i + 1; j < r.size(); ++j)
        if ((r[i] & r[j]).area() > 0) {
          r[i] |= r[j];
          r.erase(r.begin() + static_cast<long>(j));
          merged = true;
          break;
        }
  }
}

}  // namespace rs
