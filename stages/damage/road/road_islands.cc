#include "stages/damage/road/road_islands.h"

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace rs {

cv::Mat RoadIslandMask(const cv::Mat& road, const cv::Mat& pixel_area_m2, double min_area_m2) {
  if (road.type() != CV_8UC1 || pixel_area_m2.type() != CV_32FC1 || road.size() != pixel_area_m2.size())
    throw std::invalid_argument("RoadIslandMask: road must be CV_8U and pixel_area_m2 CV_32F of the same size");
  cv::Mat islands = cv::Mat::zeros(road.size(), CV_8U);
  const int w = road.cols / 2, h = road.rows / 2;
  if (!(min_area_m2 > 0) || w == 0 || h == 0) return islands;
  // 2×2 blocks: road where all four pixels are; area = their summed area on the road.
  cv::Mat blocks(h, w, CV_8U), block_area(h, w, CV_32F);
  tbb::parallel_for(0, h, [&](int y) {
    const uchar* r0 = road.ptr<uchar>(2 * y);
    const uchar* r1 = road.ptr<uchar>(2 * y + 1);
    const float* a0 = pixel_area_m2.ptr<float>(2 * y);
    const float* a1 = pixel_area_m2.ptr<float>(2 * y + 1);
    uchar* b = blocks.ptr<uchar>(y);
    float* ba = block_area.ptr<float>(y);
    auto positive = [](float a) { return a > 0 && std::isfinite(a) ? a : 0.0f; };
    for (int x = 0; x < w; ++x) {
      const int u = 2 * x;
      b[x] = r0[u] && r0[u + 1] && r1[u] && r1[u + 1] ? 255 : 0;
      ba[x] = positive(a0[u]) + positive(a0[u + 1]) + positive(a1[u]) + positive(a1[u + 1]);
    }
  });
  cv::Mat labels;
  const int n = cv::connectedComponents(blocks, labels, 8, CV_32S);
  if (n <= 1) return islands;
  std::vector<double> area(n, 0.0);
  for (int y = 0; y < h; ++y) {
    const int* l = labels.ptr<int>(y);
    const float* ba = block_area.ptr<float>(y);
    for (int x = 0; x < w; ++x) area[l[x]] += ba[x];
  }
  std::vector<uchar> small(n, 0);
  bool any = false;
  for (int i = 1; i < n; ++i) any |= (small[i] = area[i] < min_area_m2 ? 1 : 0);
  if (!any) return islands;
  tbb::parallel_for(0, h, [&](int y) {
    const int* l = labels.ptr<int>(y);
    uchar* i0 = islands.ptr<uchar>(2 * y);
    uchar* i1 = islands.ptr<uchar>(2 * y + 1);
    for (int x = 0; x < w; ++x)
      if (small[l[x]]) i0[2 * x] = i0[2 * x + 1] = i1[2 * x] = i1[2 * x + 1] = 255;
  });
  return islands;
}

int RemoveIslandLabels(cv::Mat& labels, const cv::Mat& islands, const cv::Mat& road) {
  if (labels.type() != CV_16UC1 || islands.type() != CV_8UC1 || road.type() != CV_8UC1 ||
      islands.size() != labels.size() || road.size() != labels.size())
    throw std::invalid_argument("RemoveIslandLabels: labels CV_16U, islands and road CV_8U, all of one size");
  std::vector<long long> on_island(65536, 0), on_road(65536, 0);
  int max_id = 0;
  for (int v = 0; v < labels.rows; ++v) {
    const uint16_t* l = labels.ptr<uint16_t>(v);
    const uchar* is = islands.ptr<uchar>(v);
    const uchar* r = road.ptr<uchar>(v);
    for (int u = 0; u < labels.cols; ++u) {
      if (!l[u]) continue;
      max_id = std::max(max_id, int(l[u]));
      if (is[u])
        ++on_island[l[u]];
      else if (r[u])
        ++on_road[l[u]];
    }
  }
  std::vector<uchar> drop(max_id + 1, 0);
  int dropped = 0;
  for (int id = 1; id <= max_id; ++id)
    if (on_island[id] > 0 && on_island[id] >= on_road[id]) drop[id] = 1, ++dropped;
  tbb::parallel_for(0, labels.rows, [&](int v) {
    uint16_t* l = labels.ptr<uint16_t>(v);
    const uchar* is = islands.ptr<uchar>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (l[u] && (is[u] || drop[l[u]])) l[u] = 0;
  });
  return dropped;
}

}  // namespace rs
