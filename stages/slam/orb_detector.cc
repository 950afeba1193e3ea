// Mirrors cv::ORB 4.6's computeKeyPoints step by step; the public OpenCV pieces ORB itself calls (resize,
// KeyPointsFilter, fastAtan2) are called here too, so ties and orderings come out the same. The expression
// order of the float arithmetic matters (this file is built with -ffp-contract=off).

#include "stages/slam/orb_detector.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "stages/slam/fast_corners.h"

namespace rs {
namespace {

constexpr int kHarrisBlock = 7;
constexpr float kHarrisK = 0.04f;

// Level features as ORB spreads them: a geometric series over the levels, the remainder on the last.
std::vector<int> FeaturesPerLevel(int nfeatures, double scale_factor, int nlevels) {
  std::vector<int> per_level(nlevels);
  const float factor = static_cast<float>(1.0 / scale_factor);
  float desired = nfeatures * (1 - factor) / (1 - static_cast<float>(std::pow(static_cast<double>(factor), nlevels)));
  int sum = 0;
  for (int level = 0; level < nlevels - 1; ++level) {
    per_level[level] = cvRound(desired);
    sum += per_level[level];
    desired *= factor;
  }
  per_level[nlevels - 1] = std::max(nfeatures - sum, 0);
  return per_level;
}

// Half-widths of the rows of the circular orientation patch, made symmetric about the diagonal.
std::vector<int> PatchRowHalfWidths(int half_patch) {
  std::vector<int> umax(half_patch + 2);
  const int vmax = cvFloor(half_patch * std::sqrt(2.f) / 2 + 1);
  const int vmin = cvCeil(half_patch * std::sqrt(2.f) / 2);
  for (int v = 0; v <= vmax; ++v) umax[v] = cvRound(std::sqrt(static_cast<double>(half_patch) * half_patch - v * v));
  for (int v = half_patch, v0 = 0; v >= vmin; --v) {
    while (umax[v0] == umax[v0 + 1]) ++v0;
    umax[v] = v0++;
  }
  return umax;
}

// Harris response over a 7x7 block of 3x3 Sobel-like integer gradients, in ORB's float scaling. The sums are
// exact integers, so rows of 8 (the eighth weighted 0, for the vectoriser) give OpenCV's values.
void HarrisResponses(const cv::Mat& img, std::vector<cv::KeyPoint>* kps) {
  static_assert(kHarrisBlock == 7);
  const ptrdiff_t step = static_cast<ptrdiff_t>(img.step);
  const int r = kHarrisBlock / 2;
  const float scale = 1.f / ((1 << 2) * kHarrisBlock * 255.f);
  const float scale_sq_sq = scale * scale * scale * scale;
  constexpr int kWeight[8] = {1, 1, 1, 1, 1, 1, 1, 0};
  for (cv::KeyPoint& kp : *kps) {
    // Corners lie edge_threshold (> block + 2) px inside the level, so the eighth column is readable.
    const uint8_t* p0 = img.ptr<uint8_t>(cvRound(kp.pt.y) - r) + (cvRound(kp.pt.x) - r);
    int a = 0, b = 0, c = 0;
    for (int i = 0; i < kHarrisBlock; ++i) {
      const uint8_t* up = p0 + (i - 1) * step;
      const uint8_t* mid = p0 + i * step;
      const uint8_t* down = p0 + (i + 1) * step;
      for (int j = 0; j < 8; ++j) {
        const int ix =
            ((mid[j + 1] - mid[j - 1]) * 2 + (up[j + 1] - up[j - 1]) + (down[j + 1] - down[j - 1])) * kWeight[j];
        const int iy = (down[j] - up[j]) * 2 + (down[j - 1] - up[j - 1]) + (down[j + 1] - up[j + 1]);
        a += ix * ix;
        b += iy * iy * kWeight[j];
        c += ix * iy;
      }
    }
    kp.response = (static_cast<float>(a) * b - static_cast<float>(c) * c -
                   kHarrisK * (static_cast<float>(a) + b) * (static_cast<float>(a) + b)) *
                  scale_sq_sq;
  }
}

// Row weights of the circular orientation patch, padded to whole vectors: weight[v][k] = 1 where
// |k - half_patch| <= umax[v]. Fixed-length weighted rows let the compiler vectorise the moments, and the
// integer sums are exact, so the moments (and angles) are OpenCV's.
struct CentroidPatch {
  int half = 0, width = 0;
  std::vector<int> weight;  // (half + 1) rows of `width`
};

CentroidPatch MakeCentroidPatch(int half_patch) {
  const std::vector<int> umax = PatchRowHalfWidths(half_patch);
  CentroidPatch patch;
  patch.half = half_patch;
  patch.width = (2 * half_patch + 1 + 7) & ~7;
  patch.weight.assign(static_cast<size_t>(half_patch + 1) * patch.width, 0);
  for (int v = 0; v <= half_patch; ++v)
    for (int k = 0; k < patch.width; ++k)
      patch.weight[static_cast<size_t>(v) * patch.width + k] = std::abs(k - half_patch) <= umax[v] ? 1 : 0;
  return patch;
}

// Intensity-centroid orientation over the circular patch.
void IntensityCentroidAngles(const cv::Mat& img, const CentroidPatch& patch, std::vector<cv::KeyPoint>* kps) {
  const ptrdiff_t step = static_cast<ptrdiff_t>(img.step);
  const int w = patch.width, half = patch.half;
  for (cv::KeyPoint& kp : *kps) {
    const uint8_t* center = img.ptr<uint8_t>(cvRound(kp.pt.y)) + cvRound(kp.pt.x) - half;
    int m01 = 0, m10 = 0;
    for (int k = 0; k < w; ++k) m10 += (k - half) * center[k] * patch.weight[k];
    for (int v = 1; v <= half; ++v) {
      const uint8_t* below = center + v * step;
      const uint8_t* above = center - v * step;
      const int* weight = patch.weight.data() + static_cast<size_t>(v) * w;
      int v_sum = 0;
      for (int k = 0; k < w; ++k) {
        v_sum += (below[k] - above[k]) * weight[k];
        m10 += (k - half) * (below[k] + above[k]) * weight[k];
      }
      m01 += v * v_sum;
    }
    kp.angle = cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
  }
}

}  // namespace

void DetectOrbCorners(const cv::Mat& gray, int nfeatures, float scale_factor, int nlevels, int edge_threshold,
                      int patch_size, int fast_threshold, std::vector<cv::KeyPoint>* out) {
  CV_Assert(gray.type() == CV_8UC1 && nlevels >= 1 && patch_size >= 2);
  out->clear();
  if (gray.empty()) return;
  const double factor = scale_factor;  // ORB keeps the factor as a double
  const std::vector<int> per_level = FeaturesPerLevel(nfeatures, factor, nlevels);
  const CentroidPatch patch = MakeCentroidPatch(patch_size / 2);
  // The patch rows (padded to whole vectors) and the Harris block must lie inside every level.
  CV_Assert(edge_threshold > patch.width - patch.half - 1 && edge_threshold > kHarrisBlock / 2 + 1);

  cv::Mat level_img = gray;
  std::vector<cv::KeyPoint> kps;
  for (int level = 0; level < nlevels; ++level) {
    const float scale = static_cast<float>(std::pow(factor, static_cast<double>(level)));
    if (level > 0) {
      // Each level from the previous one, sized with ORB's float inverse scale.
      const float inv_scale = 1.f / scale;
      const cv::Size size(cvRound(gray.cols * inv_scale), cvRound(gray.rows * inv_scale));
      cv::Mat resized;  // fresh, so the caller's image is never written
      cv::resize(level_img, resized, size, 0, 0, cv::INTER_LINEAR_EXACT);
      level_img = resized;
    }
    DetectFastCorners(level_img, fast_threshold, &kps);
    cv::KeyPointsFilter::runByImageBorder(kps, level_img.size(), edge_threshold);
    // Over-keep on FAST score, rank on Harris, then cull: the order of these steps decides ties.
    cv::KeyPointsFilter::retainBest(kps, 2 * per_level[level]);
    for (cv::KeyPoint& kp : kps) {
      kp.octave = level;
      kp.size = patch_size * scale;
    }
    HarrisResponses(level_img, &kps);
    cv::KeyPointsFilter::retainBest(kps, per_level[level]);
    IntensityCentroidAngles(level_img, patch, &kps);
    for (cv::KeyPoint& kp : kps) kp.pt *= scale;
    out->insert(out->end(), kps.begin(), kps.end());
  }
}

}  // namespace rs
