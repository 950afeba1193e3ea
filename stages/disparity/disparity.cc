#include "stages/disparity/disparity.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/calib3d.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "stages/disparity/perspective_transform.h"

namespace rs {
namespace {

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string Num(double x) {
  std::string s = std::to_string(x);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

// Road model from a dense disparity map (plain SGM path): a grid of valid samples.
RoadModel FitFromDense(const cv::Mat& d, const cv::Mat& valid, const RoadFitOptions& o, const RoadModel* prior) {
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(d.total()) / 4000.0)));
  std::vector<DisparitySample> s;
  for (int v = step / 2; v < d.rows; v += step)
    for (int u = step / 2; u < d.cols; u += step)
      if (valid.at<uint8_t>(v, u)) s.push_back({double(u), double(v), double(d.at<float>(v, u))});
  return FitRoadModel(s, d.cols, d.rows, o, prior);
}

}  // namespace

void DisparityParams::Check() const {
  auto fail = [](const std::string& field, const std::string& value, const std::string& rule) {
    throw std::invalid_argument("disparity." + field + " = " + value + " violates " + rule);
  };
  if (num_disparities < 1 || num_disparities > 1024)
    fail("num_disparities", std::to_string(num_disparities), "1 <= num_disparities <= 1024");
  if (p2 <= p1) fail("p2", std::to_string(p2), "p2 > p1 (p1 = " + std::to_string(p1) + ")");
  if (gpt_num_disparities < 2 || gpt_num_disparities > 1024)
    fail("gpt_num_disparities", std::to_string(gpt_num_disparities), "2 <= gpt_num_disparities <= 1024");
  if (!(gpt_delta_px >= 0) || !(gpt_delta_px < gpt_num_disparities))
    fail("gpt_delta_px", Num(gpt_delta_px), "0 <= gpt_delta_px < gpt_num_disparities (" + std::to_string(gpt_num_disparities) + ")");
  if (!(gpt_headroom_px >= 0)) fail("gpt_headroom_px", Num(gpt_headroom_px), "gpt_headroom_px >= 0");
  if (speckle_window_size < 0) fail("speckle_window_size", std::to_string(speckle_window_size), "speckle_window_size >= 0");
  if (!(gpt_min_valid_fraction >= 0 && gpt_min_valid_fraction <= 1))
    fail("gpt_min_valid_fraction", Num(gpt_min_valid_fraction), "0 <= gpt_min_valid_fraction <= 1");
  if (!(speckle_max_diff_px >= 0)) fail("speckle_max_diff_px", Num(speckle_max_diff_px), "speckle_max_diff_px >= 0");
  try {
    ToSgm(min_disparity, num_disparities).Check(0);
    road.Check();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("disparity.") + e.what());
  }
}

SgmParams DisparityParams::ToSgm(int min_d, int num_d) const {
  SgmParams s;
  s.census_width = census_width, s.census_height = census_height;
  s.ad_weight = ad_weight, s.ad_truncation = ad_truncation;
  s.num_paths = num_paths, s.p1 = p1, s.p2 = p2, s.adaptive_p2 = adaptive_p2, s.p2_gradient_scale = p2_gradient_scale;
  s.min_disparity = min_d, s.num_disparities = num_d;
  s.uniqueness_ratio = uniqueness_ratio, s.subpixel = subpixel, s.lr_max_diff = lr_max_diff;
  return s;
}

void FilterSpeckles(cv::Mat* disparity, cv::Mat* valid, int max_size, double max_diff_px) {
  if (max_size <= 0) return;
  // OpenCV's speckle filter on a 1/16-px fixed-point copy; invalid pixels carry the marker.
  constexpr int16_t kInvalid = INT16_MIN;
  cv::Mat fixed(disparity->size(), CV_16S);
  for (int v = 0; v < fixed.rows; ++v) {
    const float* d = disparity->ptr<float>(v);
    const uint8_t* m = valid->ptr<uint8_t>(v);
    int16_t* f = fixed.ptr<int16_t>(v);
    for (int u = 0; u < fixed.cols; ++u)
      f[u] = m[u] ? static_cast<int16_t>(std::clamp(cvRound(d[u] * 16.0f), -32000, 32000)) : kInvalid;
  }
  cv::filterSpeckles(fixed, kInvalid, max_size, cvRound(max_diff_px * 16.0));
  for (int v = 0; v < fixed.rows; ++v) {
    float* d = disparity->ptr<float>(v);
    uint8_t* m = valid->ptr<uint8_t>(v);
    const int16_t* f = fixed.ptr<int16_t>(v);
    for (int u = 0; u < fixed.cols; ++u)
      if (f[u] == kInvalid) m[u] = 0, d[u] = 0.0f;
  }
}

namespace {

inline void Sort2(float& a, float& b) {
  const float lo = std::min(a, b), hi = std::max(a, b);
  a = lo, b = hi;
}

// Median of 9 by a 19-exchange network (full neighbourhoods, the common case).
inline float Median9(float* p) {
  Sort2(p[1], p[2]), Sort2(p[4], p[5]), Sort2(p[7], p[8]), Sort2(p[0], p[1]), Sort2(p[3], p[4]);
  Sort2(p[6], p[7]), Sort2(p[1], p[2]), Sort2(p[4], p[5]), Sort2(p[7], p[8]), Sort2(p[0], p[3]);
  Sort2(p[5], p[8]), Sort2(p[4], p[7]), Sort2(p[3], p[6]), Sort2(p[1], p[4]), Sort2(p[2], p[5]);
  Sort2(p[4], p[7]), Sort2(p[4], p[2]), Sort2(p[6], p[4]), Sort2(p[4], p[2]);
  return p[4];
}

}  // namespace

void MedianValid3x3(cv::Mat* disparity, const cv::Mat& valid) {
  const cv::Mat src = disparity->clone();
  const int W = src.cols, H = src.rows;
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    float vals[9];
    for (int v = r.begin(); v < r.end(); ++v) {
      const uint8_t* m = valid.ptr<uint8_t>(v);
      float* dst = disparity->ptr<float>(v);
      for (int u = 0; u < W; ++u) {
        if (!m[u]) continue;
        int n = 0;
        for (int y = std::max(0, v - 1); y <= std::min(H - 1, v + 1); ++y) {
          const uint8_t* my = valid.ptr<uint8_t>(y);
          const float* sy = src.ptr<float>(y);
          for (int x = std::max(0, u - 1); x <= std::min(W - 1, u + 1); ++x)
            if (my[x]) vals[n++] = sy[x];
        }
        if (n == 9) {
          dst[u] = Median9(vals);
        } else {
          std::nth_element(vals, vals + (n - 1) / 2, vals + n);
          dst[u] = vals[(n - 1) / 2];
        }
      }
    }
  });
}

DisparityResult ComputeDisparity(const cv::Mat& left, const cv::Mat& right, const DisparityParams& P,
                                 const RoadModel* prior) {
  const auto t_start = std::chrono::steady_clock::now();
  P.Check();
  if (left.empty() || left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size())
    throw std::invalid_argument("disparity: inputs must be non-empty CV_8UC1 images of equal size");
  const int W = left.cols, H = left.rows;
  DisparityResult res;
  auto t0 = std::chrono::steady_clock::now();

  bool gpt = P.method == DisparityMethod::kGptSgm;
  if (gpt) {
    RoadFitOptions o = P.road;
    o.max_disparity_px = std::min(o.max_disparity_px, double(P.min_disparity + P.num_disparities));
    const auto samples = MatchSparseDisparities(left, right, o);
    res.road = FitRoadModel(samples, W, H, o, prior);
    res.timings.road_model_ms = MsSince(t0);
    if (!res.road.reliable) gpt = false, res.fell_back = true;
  }

  SgmOutput sgm;
  std::vector<double> kappa;
  if (gpt) {
    t0 = std::chrono::steady_clock::now();
    kappa = ComputeGptShift(res.road, W, H, P.gpt_delta_px);
    double span = 0;  // largest road residual above the row minimum
    for (int v = 0; v < H; ++v) span = std::max(span, std::max(res.road.At(0, v), res.road.At(W - 1, v)) - res.road.RowMin(v, W));
    int num_d = P.gpt_num_disparities;
    if (P.gpt_expand_range) num_d = std::max(num_d, static_cast<int>(std::ceil(P.gpt_delta_px + span + P.gpt_headroom_px)));
    num_d = std::min(num_d, 1024);
    res.num_disparities = num_d;
    SgmParams sp = P.ToSgm(0, num_d);
    cv::Mat target = right;
    if (P.gpt_subpixel_warp) {
      target = WarpTarget(right, kappa);
    } else {
      sp.row_offset.resize(H);
      for (int v = 0; v < H; ++v) sp.row_offset[v] = static_cast<int>(std::floor(kappa[v]));
    }
    res.timings.warp_ms = MsSince(t0);
    sgm = ComputeSgm(left, target, sp);
    res.method_used = DisparityMethod::kGptSgm;
  } else {
    res.num_disparities = P.num_disparities;
    sgm = ComputeSgm(left, right, P.ToSgm(P.min_disparity, P.num_disparities));
    res.method_used = DisparityMethod::kSgm;
  }
  res.timings.census_ms = sgm.census_ms;
  res.timings.aggregation_ms = sgm.aggregation_ms;
  res.timings.wta_ms = sgm.wta_ms;

  t0 = std::chrono::steady_clock::now();
  FilterSpeckles(&sgm.disparity, &sgm.valid, P.speckle_window_size, P.speckle_max_diff_px);
  if (P.median) MedianValid3x3(&sgm.disparity, sgm.valid);
  res.timings.postprocess_ms = MsSince(t0);

  t0 = std::chrono::steady_clock::now();
  res.valid = sgm.valid;
  if (gpt && P.gpt_subpixel_warp) {
    res.disparity = TrueFromWarpedDisparity(sgm.disparity, sgm.valid, kappa);
  } else {
    res.disparity = sgm.disparity;
  }
  // A match outside the target image is unobservable: after a sub-pixel warp the replicated
  // border can still "match", so drop those explicitly (plain SGM already rejects them).
  for (int v = 0; v < H; ++v) {
    float* d = res.disparity.ptr<float>(v);
    uint8_t* m = res.valid.ptr<uint8_t>(v);
    for (int u = 0; u < W; ++u)
      if (m[u] && (u - d[u] < 0 || u - d[u] > W - 1)) m[u] = 0, d[u] = 0.0f;
  }
  if (gpt && P.gpt_min_valid_fraction > 0) {
    int64_t visible = 0, visible_valid = 0;
    for (int v = 0; v < H; ++v) {
      const uint8_t* m = res.valid.ptr<uint8_t>(v);
      const double x_min = res.road.At(0, v), slope = res.road.At(1, v) - x_min;  // visible: u - road >= 0
      for (int u = 0; u < W; ++u)
        if (u - (res.road.quadratic ? res.road.At(u, v) : x_min + slope * u) >= 0) ++visible, visible_valid += m[u] != 0;
    }
    if (visible == 0 || visible_valid < P.gpt_min_valid_fraction * visible) {
      DisparityParams plain = P;
      plain.method = DisparityMethod::kSgm;
      DisparityResult r = ComputeDisparity(left, right, plain, prior);
      r.fell_back = true;
      r.timings.total_ms = MsSince(t_start);
      return r;
    }
  }
  if (!gpt) {
    const auto tr = std::chrono::steady_clock::now();
    res.road = FitFromDense(res.disparity, res.valid, P.road, prior);
    res.timings.road_model_ms += MsSince(tr);
  }
  if (res.road.reliable) {
    res.transformed = TransformedDisparity(res.disparity, res.valid, res.road, P.gpt_delta_px);
  } else {
    res.transformed = cv::Mat::zeros(H, W, CV_32F);
  }
  res.valid_fraction = static_cast<double>(cv::countNonZero(res.valid)) / static_cast<double>(res.valid.total());
  res.timings.transform_ms = MsSince(t0);
  res.timings.total_ms = MsSince(t_start);
  return res;
}

}  // namespace rs
