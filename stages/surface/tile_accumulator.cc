#include "stages/surface/tile_accumulator.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>

#include "formats/checked_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kHuberK = 2.0;
constexpr int kHuberIterations = 3;

// Inverse-variance weighted median of n observations (n ≥ 1).
double WeightedMedian(const CellObservation* obs, int n) {
  std::pair<double, double> hw[256];
  double total = 0;
  for (int i = 0; i < n; ++i) {
    const double w = 1.0 / (double(obs[i].sigma_m) * obs[i].sigma_m);
    hw[i] = {obs[i].height_m, w};
    total += w;
  }
  std::sort(hw, hw + n);
  double acc = 0;
  for (int i = 0; i < n; ++i) {
    acc += hw[i].second;
    if (acc >= 0.5 * total) return hw[i].first;
  }
  return hw[n - 1].first;
}

}  // namespace

bool FuseCell(const CellObservation* obs, int n, float* height_m, float* sigma_m) {
  if (n <= 0) return false;
  double h = WeightedMedian(obs, n);
  double sum_w = 0;
  for (int it = 0; it < kHuberIterations; ++it) {
    double sw = 0, swh = 0;
    for (int i = 0; i < n; ++i) {
      const double s = obs[i].sigma_m;
      const double r = std::abs(obs[i].height_m - h) / s;
      const double w = (r <= kHuberK ? 1.0 : kHuberK / r) / (s * s);
      sw += w;
      swh += w * obs[i].height_m;
    }
    h = swh / sw;
    sum_w = sw;
  }
  // Reduced chi-square of the Huber-weighted fit: above 1 the views disagree beyond their σ
  // (pose error, texture), and the fused σ says so.
  double chi2 = 0;
  for (int i = 0; i < n; ++i) {
    const double r = (obs[i].height_m - h) / obs[i].sigma_m;
    chi2 += std::min(r * r, kHuberK * kHuberK);
  }
  const double inflate = n > 1 ? std::max(1.0, chi2 / (n - 1)) : 1.0;
  *height_m = static_cast<float>(h);
  *sigma_m = static_cast<float>(std::sqrt(inflate / sum_w));
  return true;
}

TileAccumulator::TileAccumulator(int cells, int keep)
    : cells_(cells), keep_(std::clamp(keep, 1, 255)), obs_(size_t(cells) * keep_), used_(cells, 0), seen_(cells, 0) {}

void TileAccumulator::Add(int cell, const CellObservation& o) {
  if (seen_[cell] < std::numeric_limits<uint16_t>::max()) ++seen_[cell];
  CellObservation* slot = &obs_[size_t(cell) * keep_];
  const int n = used_[cell];
  if (n < keep_) {
    slot[n] = o;
    used_[cell] = static_cast<uint8_t>(n + 1);
  } else {
    // Full: the new view replaces the least certain one if it is better.
    int worst = 0;
    for (int i = 1; i < n; ++i)
      if (slot[i].sigma_m > slot[worst].sigma_m) worst = i;
    if (o.sigma_m < slot[worst].sigma_m) slot[worst] = o;
  }
}

FusedTile TileAccumulator::Fuse(int side, int min_views) const {
  FusedTile t;
  t.height_m.create(side, side, CV_32F);
  t.sigma_m.create(side, side, CV_32F);
  t.count.create(side, side, CV_16U);
  t.colour.create(side, side, CV_8UC3);
  for (int c = 0; c < cells_; ++c) {
    const int r = c / side, col = c % side;
    const CellObservation* slot = &obs_[size_t(c) * keep_];
    float h = kNaN, s = kNaN;
    cv::Vec3b bgr(0, 0, 0);
    const bool enough = seen_[c] >= min_views;
    if (enough && FuseCell(slot, used_[c], &h, &s)) {
      const CellObservation* best = std::min_element(
          slot, slot + used_[c], [](const CellObservation& a, const CellObservation& b) { return a.sigma_m < b.sigma_m; });
      bgr = {best->bgr[0], best->bgr[1], best->bgr[2]};
    }
    t.height_m.at<float>(r, col) = h;
    t.sigma_m.at<float>(r, col) = s;
    t.count.at<uint16_t>(r, col) = enough ? seen_[c] : 0;
    t.colour.at<cv::Vec3b>(r, col) = bgr;
  }
  return t;
}

size_t TileAccumulator::bytes() const {
  return obs_.size() * sizeof(CellObservation) + used_.size() + seen_.size() * sizeof(uint16_t);
}

void TileAccumulator::Save(const fs::path& path) const {
  std::string bytes;
  bytes.reserve(this->bytes() + 8);
  const int32_t head[2] = {cells_, keep_};
  bytes.append(reinterpret_cast<const char*>(head), sizeof(head));
  bytes.append(reinterpret_cast<const char*>(obs_.data()), obs_.size() * sizeof(CellObservation));
  bytes.append(reinterpret_cast<const char*>(used_.data()), used_.size());
  bytes.append(reinterpret_cast<const char*>(seen_.data()), seen_.size() * sizeof(uint16_t));
  WriteFileChecked(path, bytes);
}

TileAccumulator TileAccumulator::Load(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  int32_t head[2] = {0, 0};
  if (!in.read(reinterpret_cast<char*>(head), sizeof(head)) || head[0] <= 0 || head[1] <= 0)
    throw std::runtime_error("surface: cannot read the spilled tile " + path.string());
  TileAccumulator t(head[0], head[1]);
  in.read(reinterpret_cast<char*>(t.obs_.data()), std::streamsize(t.obs_.size() * sizeof(CellObservation)));
  in.read(reinterpret_cast<char*>(t.used_.data()), std::streamsize(t.used_.size()));
  in.read(reinterpret_cast<char*>(t.seen_.data()), std::streamsize(t.seen_.size() * sizeof(uint16_t)));
  if (!in) throw std::runtime_error("surface: the spilled tile " + path.string() + " is cut short");
  return t;
}

}  // namespace rs
