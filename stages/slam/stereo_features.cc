#include "stages/slam/stereo_features.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>

#include <opencv2/features2d.hpp>
#include <tbb/parallel_invoke.h>

#include "stages/slam/orb_detector.h"

namespace rs {

ScalePyramid::ScalePyramid(int levels, double factor) {
  scale.resize(levels);
  sigma2.resize(levels);
  inv_sigma2.resize(levels);
  for (int i = 0; i < levels; ++i) {
    scale[i] = std::pow(factor, i);
    sigma2[i] = scale[i] * scale[i];
    inv_sigma2[i] = 1.0 / sigma2[i];
  }
}

int ScalePyramid::PredictLevel(double distance_m, double max_distance_m) const {
  if (levels() <= 1 || distance_m <= 0) return 0;
  const double ratio = max_distance_m / distance_m;
  int level = static_cast<int>(std::ceil(std::log(ratio) / std::log(scale[1])));
  return std::clamp(level, 0, levels() - 1);
}

void StereoFeatures::BuildGrid(int width, int height) {
  grid_cols = std::max(1, static_cast<int>(std::ceil(width / kGridCellPx)));
  grid_rows = std::max(1, static_cast<int>(std::ceil(height / kGridCellPx)));
  grid.assign(static_cast<size_t>(grid_cols) * grid_rows, {});
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const int cx = std::clamp(static_cast<int>(keypoints[i].pt.x / kGridCellPx), 0, grid_cols - 1);
    const int cy = std::clamp(static_cast<int>(keypoints[i].pt.y / kGridCellPx), 0, grid_rows - 1);
    grid[static_cast<size_t>(cy) * grid_cols + cx].push_back(static_cast<int>(i));
  }
}

std::vector<int> StereoFeatures::FeaturesInArea(double u, double v, double radius, int min_level, int max_level) const {
  std::vector<int> out;
  if (grid.empty()) return out;
  const int x0 = std::max(0, static_cast<int>(std::floor((u - radius) / kGridCellPx)));
  const int x1 = std::min(grid_cols - 1, static_cast<int>(std::floor((u + radius) / kGridCellPx)));
  const int y0 = std::max(0, static_cast<int>(std::floor((v - radius) / kGridCellPx)));
  const int y1 = std::min(grid_rows - 1, static_cast<int>(std::floor((v + radius) / kGridCellPx)));
  const double r2 = radius * radius;
  for (int gy = y0; gy <= y1; ++gy) {
    for (int gx = x0; gx <= x1; ++gx) {
      for (int i : grid[static_cast<size_t>(gy) * grid_cols + gx]) {
        const cv::KeyPoint& kp = keypoints[i];
        if (min_level >= 0 && kp.octave < min_level) continue;
        if (max_level >= 0 && kp.octave > max_level) continue;
        const double dx = kp.pt.x - u, dy = kp.pt.y - v;
        if (dx * dx + dy * dy <= r2) out.push_back(i);
      }
    }
  }
  return out;
}

void ExtractOrb(const cv::Mat& gray, const SlamOptions& options, std::vector<cv::KeyPoint>* keypoints,
                cv::Mat* descriptors) {
  // Over-detect, then spread: cv::ORB ranks by Harris score only, which clusters features on
  // strong texture and starves the rest of the image (bad geometry for pose estimation).
  cv::Ptr<cv::ORB> orb =
      cv::ORB::create(options.features * 2, static_cast<float>(options.scale_factor), options.pyramid_levels, 19, 0, 2,
                      cv::ORB::HARRIS_SCORE, 31, options.fast_threshold);
  // DetectOrbCorners is orb->detect bit for bit (orb_detector_test.cc), with a vectorised FAST.
  std::vector<cv::KeyPoint> all;
  DetectOrbCorners(gray, options.features * 2, static_cast<float>(options.scale_factor), options.pyramid_levels, 19, 31,
                   options.fast_threshold, &all);
  const std::vector<cv::KeyPoint> detected = all;  // cv::ORB's own coordinates, for its descriptors below
  // cv::ORB maps a level-k corner to level 0 as x_k * scale_k, but its pyramid is resized with the
  // pixel-centre convention, x_0 = (x_k + 0.5) * W_0 / W_k - 0.5: without this the coordinates of
  // coarse-level corners are 0.5 (scale - 1) px too small (1.3 px at level 7), which biases the stereo
  // disparity (the right position is refined on level 0) and with it every depth.
  for (cv::KeyPoint& kp : all) {
    if (kp.octave <= 0) continue;
    const double s = std::pow(options.scale_factor, kp.octave);
    const double wk = std::round(gray.cols / s), hk = std::round(gray.rows / s);
    kp.pt.x = static_cast<float>((kp.pt.x / s + 0.5) * gray.cols / wk - 0.5);
    kp.pt.y = static_cast<float>((kp.pt.y / s + 0.5) * gray.rows / hk - 0.5);
  }
  const int cell = options.grid_cell_px;
  const int cols = std::max(1, (gray.cols + cell - 1) / cell), rows = std::max(1, (gray.rows + cell - 1) / cell);
  std::vector<int> order(all.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return all[a].response > all[b].response; });
  const int cap = std::max(1, (options.features + cols * rows - 1) / (cols * rows));
  std::vector<int> count(static_cast<size_t>(cols) * rows, 0);
  std::vector<char> taken(all.size(), 0);
  std::vector<int> keep;
  for (int i : order) {
    if (static_cast<int>(keep.size()) >= options.features) break;
    const int cx = std::clamp(static_cast<int>(all[i].pt.x) / cell, 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(all[i].pt.y) / cell, 0, rows - 1);
    int& c = count[static_cast<size_t>(cy) * cols + cx];
    if (c < cap) {
      ++c;
      taken[i] = 1;
      keep.push_back(i);
    }
  }
  for (int i : order) {
    if (static_cast<int>(keep.size()) >= options.features) break;
    if (!taken[i]) keep.push_back(i);
  }
  std::sort(keep.begin(), keep.end());
  // Descriptors of the kept corners only (half the over-detected set): cv::ORB computes them on the same
  // pyramid and smoothing as detectAndCompute would, so they are the same bits.
  std::vector<cv::KeyPoint> kept;
  kept.reserve(keep.size());
  for (int i : keep) kept.push_back(detected[i]);
  orb->compute(gray, kept, *descriptors);
  if (kept.size() != keep.size())
    throw std::logic_error("ExtractOrb: cv::ORB::compute dropped corners that cv::ORB::detect returned");
  keypoints->clear();
  keypoints->reserve(keep.size());
  for (int i : keep) keypoints->push_back(all[i]);
}

namespace {

// Sum of absolute differences of the (2w+1)^2 patches centred at (xl, y) left and (xr, y) right.
int PatchSad(const cv::Mat& left, const cv::Mat& right, int xl, int xr, int y, int w) {
  int sad = 0;
  for (int dy = -w; dy <= w; ++dy) {
    const uint8_t* l = left.ptr<uint8_t>(y + dy) + xl - w;
    const uint8_t* r = right.ptr<uint8_t>(y + dy) + xr - w;
    for (int dx = 0; dx <= 2 * w; ++dx) sad += std::abs(static_cast<int>(l[dx]) - static_cast<int>(r[dx]));
  }
  return sad;
}

}  // namespace

StereoFeatures ExtractStereoFeatures(const cv::Mat& left, const cv::Mat& right, const RectifiedStereo& camera,
                                     const SlamOptions& options, const ScalePyramid& pyramid) {
  OrbFeatures l, r;
  if (options.parallel) {
    tbb::parallel_invoke([&] { ExtractOrb(left, options, &l.keypoints, &l.descriptors); },
                         [&] { ExtractOrb(right, options, &r.keypoints, &r.descriptors); });
  } else {
    ExtractOrb(left, options, &l.keypoints, &l.descriptors);
    ExtractOrb(right, options, &r.keypoints, &r.descriptors);
  }
  return MatchStereo(left, right, std::move(l), r, camera, options, pyramid);
}

StereoFeatures MatchStereo(const cv::Mat& left, const cv::Mat& right, OrbFeatures left_features,
                           const OrbFeatures& right_features, const RectifiedStereo& camera, const SlamOptions& options,
                           const ScalePyramid& pyramid) {
  StereoFeatures f;
  f.keypoints = std::move(left_features.keypoints);
  f.descriptors = left_features.descriptors;
  const std::vector<cv::KeyPoint>& right_kps = right_features.keypoints;
  const cv::Mat& right_desc = right_features.descriptors;
  const size_t n = f.keypoints.size();
  f.u_right.assign(n, -1.f);
  f.depth_m.assign(n, -1.f);

  // Right features listed under every image row their (scale-dependent) band covers.
  const int rows = right.rows;
  std::vector<std::vector<int>> row_index(rows);
  for (size_t j = 0; j < right_kps.size(); ++j) {
    const double y = right_kps[j].pt.y, r = 2.0 * pyramid.scale[right_kps[j].octave];
    const int y0 = std::max(0, static_cast<int>(std::floor(y - r))),
              y1 = std::min(rows - 1, static_cast<int>(std::ceil(y + r)));
    for (int yy = y0; yy <= y1; ++yy) row_index[yy].push_back(static_cast<int>(j));
  }
  const double min_disparity = 0, max_disparity = camera.f_px;  // depth >= one baseline
  constexpr int kW = 5, kL = 5;
  std::vector<std::pair<int, int>> sad_of;  // (sad, feature)
  for (size_t i = 0; i < n; ++i) {
    const cv::KeyPoint& kp = f.keypoints[i];
    const int y = static_cast<int>(std::lround(kp.pt.y));
    if (y < 0 || y >= rows) continue;
    const double ul = kp.pt.x;
    int best = 256, best_j = -1;
    for (int j : row_index[y]) {
      const cv::KeyPoint& kr = right_kps[j];
      if (kr.octave < kp.octave - 1 || kr.octave > kp.octave + 1) continue;
      const double d = ul - kr.pt.x;
      if (d < min_disparity || d > max_disparity) continue;
      const int dist = DescriptorDistance(f.descriptors.ptr<uint8_t>(static_cast<int>(i)), right_desc.ptr<uint8_t>(j));
      if (dist < best) {
        best = dist;
        best_j = j;
      }
    }
    if (best_j < 0 || best > options.stereo_max_hamming) continue;
    // Sub-pixel: SAD over a window slid along the row, parabola through the minimum.
    const int xl = static_cast<int>(std::lround(ul)), xr0 = static_cast<int>(std::lround(right_kps[best_j].pt.x));
    if (y - kW < 0 || y + kW >= rows || xl - kW < 0 || xl + kW >= left.cols) continue;
    if (xr0 - kL - kW - 1 < 0 || xr0 + kL + kW + 1 >= right.cols) continue;
    int sads[2 * kL + 3];
    int best_sad = INT32_MAX, best_off = 0;
    for (int off = -kL - 1; off <= kL + 1; ++off) {
      const int s = PatchSad(left, right, xl, xr0 + off, y, kW);
      sads[off + kL + 1] = s;
      if (off >= -kL && off <= kL && s < best_sad) {
        best_sad = s;
        best_off = off;
      }
    }
    const double s_m = sads[best_off + kL], s_0 = sads[best_off + kL + 1], s_p = sads[best_off + kL + 2];
    const double denom = 2.0 * (s_m - 2.0 * s_0 + s_p);
    if (denom <= 0) continue;
    const double delta = (s_m - s_p) / denom;
    if (delta < -1 || delta > 1) continue;
    // The SAD window was centred on the rounded left position xl: the disparity is xl - ur, and the
    // right position that goes with the keypoint's sub-pixel ul is shifted alike (u_left - u_right
    // must equal the disparity the depth came from).
    // options.disparity_offset_px corrects a residual rectification error (calibration input).
    const double ur = xr0 + best_off + delta - options.disparity_offset_px;
    const double disparity = xl - ur;
    if (disparity <= 0.05 || disparity >= max_disparity || ur + (ul - xl) < 0) continue;
    f.u_right[i] = static_cast<float>(ur + (ul - xl));
    f.depth_m[i] = static_cast<float>(camera.bf() / disparity);
    sad_of.emplace_back(best_sad, static_cast<int>(i));
  }
  // Drop matches whose patch difference is far above typical: repeated texture picked the wrong twin.
  if (!sad_of.empty()) {
    std::vector<int> sads;
    for (auto& p : sad_of) sads.push_back(p.first);
    std::nth_element(sads.begin(), sads.begin() + sads.size() / 2, sads.end());
    const double limit = 1.5 * 1.4 * sads[sads.size() / 2];
    for (auto& [s, i] : sad_of) {
      if (s > limit) {
        f.u_right[i] = -1.f;
        f.depth_m[i] = -1.f;
      }
    }
  }
  f.BuildGrid(camera.width, camera.height);
  return f;
}

}  // namespace rs
