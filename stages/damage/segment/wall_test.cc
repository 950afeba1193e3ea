#include "stages/damage/segment/wall_test.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "survey/stats/order_statistic.h"

namespace rs {
namespace {

// Slope magnitude of `value` smoothed over valid pixels only (normalised convolution): invalid
// pixels neither pull the surface nor make an edge. NaN where the neighbourhood holds none.
cv::Mat SlopeMagnitude(const cv::Mat& value, const cv::Mat& valid, double smooth_px) {
  cv::Mat w, vw;
  valid.convertTo(w, CV_32F, 1.0 / 255.0);
  cv::Mat masked = value.mul(w);
  cv::GaussianBlur(masked, vw, cv::Size(), smooth_px);
  cv::GaussianBlur(w, w, cv::Size(), smooth_px);
  cv::Mat smooth = vw / cv::max(w, 1e-6);
  cv::Mat gu, gv, mag;
  cv::Sobel(smooth, gu, CV_32F, 1, 0, 1, 0.5);  // central difference: (x[u+1] − x[u−1]) / 2
  cv::Sobel(smooth, gv, CV_32F, 0, 1, 1, 0.5);
  cv::magnitude(gu, gv, mag);
  mag.setTo(std::numeric_limits<float>::quiet_NaN(), w < 0.5f);
  return mag;
}

}  // namespace

ReliefSlope MeasureReliefSlope(const cv::Mat& value, const cv::Mat& valid, const cv::Mat& labels, double smooth_px) {
  if (value.type() != CV_32FC1 || valid.type() != CV_8UC1 || labels.type() != CV_16UC1 ||
      valid.size() != value.size() || labels.size() != value.size())
    throw std::invalid_argument("MeasureReliefSlope: CV_32F value, CV_8U valid and CV_16U labels of one size");
  ReliefSlope out;
  out.magnitude = SlopeMagnitude(value, valid, smooth_px);
  std::vector<float> road;  // every second pixel outside every instance
  for (int v = 0; v < value.rows; v += 2) {
    const float* s = out.magnitude.ptr<float>(v);
    const uint16_t* l = labels.ptr<uint16_t>(v);
    for (int u = 0; u < value.cols; u += 2)
      if (l[u] == 0 && std::isfinite(s[u])) road.push_back(s[u]);
  }
  out.noise = road.empty() ? 0.0 : LowerMedianInPlace(road) / 1.177;
  return out;
}

std::vector<double> WallSteepness(const ReliefSlope& slope, const cv::Mat& labels, int count, int band_px) {
  std::vector<double> out(count + 1, std::numeric_limits<double>::quiet_NaN());
  if (count <= 0 || !(slope.noise > 0)) return out;
  // Inner band: instance pixels within band_px of another label (erosion of each id's mask).
  cv::Mat eroded;
  cv::erode(labels, eroded, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * band_px + 1, 2 * band_px + 1}));
  std::vector<std::vector<float>> band(count + 1);
  for (int v = 0; v < labels.rows; ++v) {
    const uint16_t* l = labels.ptr<uint16_t>(v);
    const uint16_t* e = eroded.ptr<uint16_t>(v);
    const float* s = slope.magnitude.ptr<float>(v);
    for (int u = 0; u < labels.cols; ++u)
      if (l[u] > 0 && l[u] <= count && e[u] != l[u] && std::isfinite(s[u])) band[l[u]].push_back(s[u]);
  }
  for (int id = 1; id <= count; ++id)
    if (!band[id].empty()) out[id] = LowerMedianInPlace(band[id]) / slope.noise;
  return out;
}

int DropInstancesWithoutWall(cv::Mat* labels, int* count, const std::vector<double>& steepness,
                             double min_steepness) {
  std::vector<uint16_t> new_id(*count + 1, 0);
  int kept = 0;
  for (int id = 1; id <= *count; ++id)
    if (!(steepness[id] < min_steepness)) new_id[id] = static_cast<uint16_t>(++kept);
  const int dropped = *count - kept;
  if (dropped == 0) return 0;
  for (int v = 0; v < labels->rows; ++v) {
    uint16_t* l = labels->ptr<uint16_t>(v);
    for (int u = 0; u < labels->cols; ++u) l[u] = new_id[l[u]];
  }
  *count = kept;
  return dropped;
}

}  // namespace rs
