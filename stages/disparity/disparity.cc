#include "stages/disparity/disparity.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

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
  // Same definition as OpenCV's filterSpeckles on a 1/16-px fixed-point copy: the connected
  // components of the graph joining 4-neighbours that are both valid and differ by at most
  // max_diff (fixed point); components of at most max_size pixels are dropped. Components do not
  // depend on the labelling order, so horizontal strips are labelled in parallel (breadth-first
  // search inside each strip) and the parts joined across strip borders by union-find.
  const int H = disparity->rows, W = disparity->cols, max_diff = cvRound(max_diff_px * 16.0);
  constexpr int16_t kInvalid = INT16_MIN;
  thread_local cv::Mat tls_fixed, tls_labels;  // reused: a fresh 5 MB per frame costs page faults
  cv::Mat& fixed = tls_fixed;
  cv::Mat& labels = tls_labels;
  fixed.create(H, W, CV_16S);
  labels.create(H, W, CV_32S);
  const int nstrips = std::clamp(H / 32, 1, 32);  // enough strips to balance 2+ threads
  std::vector<int> strip_row(nstrips + 1);
  for (int s = 0; s <= nstrips; ++s) strip_row[s] = static_cast<int>(static_cast<int64_t>(s) * H / nstrips);
  std::vector<std::vector<int>> strip_sizes(nstrips);  // pixels per strip-local label
  const ptrdiff_t fstep = static_cast<ptrdiff_t>(fixed.step1()), lstep = static_cast<ptrdiff_t>(labels.step1());
  int16_t* const F = fixed.ptr<int16_t>(0);
  int* const Lb = labels.ptr<int>(0);
  tbb::parallel_for(0, nstrips, [&](int s) {
    const int v0 = strip_row[s], v1 = strip_row[s + 1];
    for (int v = v0; v < v1; ++v) {
      const float* d = disparity->ptr<float>(v);
      const uint8_t* m = valid->ptr<uint8_t>(v);
      int16_t* f = F + v * fstep;
      int* l = Lb + v * lstep;
      for (int u = 0; u < W; ++u) {
        f[u] = m[u] ? static_cast<int16_t>(std::clamp(cvRound(d[u] * 16.0f), -32000, 32000)) : kInvalid;
        l[u] = -1;
      }
    }
    // Locals, not captures: the label stores would otherwise force reloads through the closure.
    int16_t* const f0 = F;
    int* const l0 = Lb;
    const ptrdiff_t fs = fstep, ls = lstep;
    const int width = W, diff = max_diff;
    std::vector<int> sizes;
    struct Pixel {
      int v, u;
    };
    std::vector<Pixel> stack;
    stack.reserve(4096);
    for (int v = v0; v < v1; ++v) {
      for (int u = 0; u < width; ++u) {
        if (f0[v * fs + u] == kInvalid || l0[v * ls + u] >= 0) continue;
        const int label = static_cast<int>(sizes.size());
        int count = 0;
        l0[v * ls + u] = label;
        stack.push_back({v, u});
        while (!stack.empty()) {
          const Pixel p = stack.back();
          stack.pop_back();
          ++count;
          const int16_t* fr = f0 + p.v * fs + p.u;
          int* lr = l0 + p.v * ls + p.u;
          const int fp = *fr;
          if (p.v + 1 < v1 && lr[ls] < 0 && fr[fs] != kInvalid && std::abs(fp - fr[fs]) <= diff)
            lr[ls] = label, stack.push_back({p.v + 1, p.u});
          if (p.v > v0 && lr[-ls] < 0 && fr[-fs] != kInvalid && std::abs(fp - fr[-fs]) <= diff)
            lr[-ls] = label, stack.push_back({p.v - 1, p.u});
          if (p.u + 1 < width && lr[1] < 0 && fr[1] != kInvalid && std::abs(fp - fr[1]) <= diff)
            lr[1] = label, stack.push_back({p.v, p.u + 1});
          if (p.u > 0 && lr[-1] < 0 && fr[-1] != kInvalid && std::abs(fp - fr[-1]) <= diff)
            lr[-1] = label, stack.push_back({p.v, p.u - 1});
        }
        sizes.push_back(count);
      }
    }
    strip_sizes[s] = std::move(sizes);
  });
  // Global label = strip base + local label; union-find over labels joins parts across strips.
  std::vector<int> base(nstrips + 1, 0);
  for (int s = 0; s < nstrips; ++s) base[s + 1] = base[s] + static_cast<int>(strip_sizes[s].size());
  std::vector<int> parent(base[nstrips]), size(base[nstrips]);
  for (int s = 0; s < nstrips; ++s)
    for (size_t k = 0; k < strip_sizes[s].size(); ++k) parent[base[s] + k] = base[s] + static_cast<int>(k), size[base[s] + k] = strip_sizes[s][k];
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (int s = 1; s < nstrips; ++s) {
    const int v = strip_row[s];
    const int16_t *fa = fixed.ptr<int16_t>(v - 1), *fb = fixed.ptr<int16_t>(v);
    const int *la = labels.ptr<int>(v - 1), *lb = labels.ptr<int>(v);
    for (int u = 0; u < W; ++u) {
      if (fa[u] == kInvalid || fb[u] == kInvalid || std::abs(fa[u] - fb[u]) > max_diff) continue;
      int a = find(base[s - 1] + la[u]), b = find(base[s] + lb[u]);
      if (a == b) continue;
      if (b < a) std::swap(a, b);
      parent[b] = a, size[a] += size[b];
    }
  }
  std::vector<uint8_t> drop(parent.size());
  for (size_t k = 0; k < parent.size(); ++k) drop[k] = size[find(static_cast<int>(k))] <= max_size;
  tbb::parallel_for(0, nstrips, [&](int s) {
    for (int v = strip_row[s]; v < strip_row[s + 1]; ++v) {
      float* d = disparity->ptr<float>(v);
      uint8_t* m = valid->ptr<uint8_t>(v);
      const int* l = labels.ptr<int>(v);
      for (int u = 0; u < W; ++u)
        if (!m[u] || drop[base[s] + l[u]]) m[u] = 0, d[u] = 0.0f;
    }
  });
}

namespace {

using vf = float __attribute__((vector_size(64)));  // 16 floats (one AVX-512 register, two AVX2)
constexpr int kFloats = 16;

inline void Sort2(vf& a, vf& b) {
  const vf lo = a < b ? a : b, hi = a < b ? b : a;
  a = lo, b = hi;
}

// The same 19-exchange network as Median9, on 16 pixels at once.
inline vf Median9(vf* p) {
  Sort2(p[1], p[2]), Sort2(p[4], p[5]), Sort2(p[7], p[8]), Sort2(p[0], p[1]), Sort2(p[3], p[4]);
  Sort2(p[6], p[7]), Sort2(p[1], p[2]), Sort2(p[4], p[5]), Sort2(p[7], p[8]), Sort2(p[0], p[3]);
  Sort2(p[5], p[8]), Sort2(p[4], p[7]), Sort2(p[3], p[6]), Sort2(p[1], p[4]), Sort2(p[2], p[5]);
  Sort2(p[4], p[7]), Sort2(p[4], p[2]), Sort2(p[6], p[4]), Sort2(p[4], p[2]);
  return p[4];
}

}  // namespace

void MedianValid3x3(cv::Mat* disparity, const cv::Mat& valid) {
  thread_local cv::Mat tls_src;  // reused: a fresh copy per frame costs page faults
  cv::Mat& src = tls_src;
  disparity->copyTo(src);
  const int W = src.cols, H = src.rows;
  using vi = int32_t __attribute__((vector_size(4 * kFloats)));
  using vb = uint8_t __attribute__((vector_size(kFloats)));
  constexpr float kInf = std::numeric_limits<float>::infinity();
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    float vals[9];
    const std::vector<uint8_t> no_valid(W, 0);  // the row beyond the image border
    const std::vector<float> no_value(W, 0.0f);
    for (int v = r.begin(); v < r.end(); ++v) {
      const uint8_t* mrow[3] = {v > 0 ? valid.ptr<uint8_t>(v - 1) : no_valid.data(), valid.ptr<uint8_t>(v),
                                v + 1 < H ? valid.ptr<uint8_t>(v + 1) : no_valid.data()};
      const float* srow[3] = {v > 0 ? src.ptr<float>(v - 1) : no_value.data(), src.ptr<float>(v),
                              v + 1 < H ? src.ptr<float>(v + 1) : no_value.data()};
      const uint8_t* m = mrow[1];
      float* dst = disparity->ptr<float>(v);
      auto general = [&](int u) {  // scalar: image borders and the row tail
        int n = 0;
        for (int y = 0; y < 3; ++y)
          for (int x = std::max(0, u - 1); x <= std::min(W - 1, u + 1); ++x)
            if (mrow[y][x]) vals[n++] = srow[y][x];
        for (int a = 1; a < n; ++a)  // insertion sort of at most 9 values
          for (int b = a; b > 0 && vals[b] < vals[b - 1]; --b) std::swap(vals[b], vals[b - 1]);
        dst[u] = vals[(n - 1) / 2];
      };
      int u = 0;
      if (m[0]) general(0);
      // 16 pixels at once. The lower median of the n valid neighbours is the plain median of 9
      // once the 9 - n invalid ones are replaced by k = 4 - (n - 1) / 2 times -inf and the rest
      // +inf (k values sort below the n valid ones, and 4 - k = (n - 1) / 2).
      for (u = 1; u + kFloats <= W - 1; u += kFloats) {
        vf p[9];
        vb b[9], any_invalid = vb{};
        for (int y = 0; y < 3; ++y)
          for (int dx = 0; dx < 3; ++dx) {
            std::memcpy(&p[3 * y + dx], srow[y] + u - 1 + dx, sizeof(vf));
            std::memcpy(&b[3 * y + dx], mrow[y] + u - 1 + dx, sizeof(vb));
            any_invalid |= reinterpret_cast<vb>(b[3 * y + dx] == 0);
          }
        uint64_t flags[2];
        std::memcpy(flags, &any_invalid, sizeof(flags));
        if ((flags[0] | flags[1]) == 0) {  // all 9 neighbours of all 16 pixels valid: the common case
          const vf md = Median9(p);
          std::memcpy(dst + u, &md, sizeof(md));
          continue;
        }
        vi ok[9], n = vi{};
        for (int q = 0; q < 9; ++q) ok[q] = __builtin_convertvector(b[q], vi) != 0, n -= ok[q];
        const vi k = 4 - (n - 1) / 2;
        vi low = vi{};  // invalid neighbours replaced so far
        for (int q = 0; q < 9; ++q) {
          const vf pad = low < k ? vf{} - kInf : vf{} + kInf;
          p[q] = ok[q] ? p[q] : pad;
          low += ok[q] ? 0 : 1;
        }
        const vf md = Median9(p);
        vf old;
        std::memcpy(&old, dst + u, sizeof(old));
        const vf out = ok[4] ? md : old;  // ok[4]: the centre pixel
        std::memcpy(dst + u, &out, sizeof(out));
      }
      for (; u < W; ++u)
        if (m[u]) general(u);
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
  const bool warped = gpt && P.gpt_subpixel_warp;
  res.disparity = sgm.disparity;  // after a warp, converted in place below (no fresh 4 MB per frame)
  if (gpt) res.transformed.create(H, W, CV_32F);  // the road model is known (reliable): fused below
  // One parallel pass: true disparity (d = l + kappa after a sub-pixel warp), a match outside
  // the target image dropped (after a warp the replicated border can still "match"; plain SGM
  // already rejects them), and per-row counts for the fall-back rule and the density.
  std::vector<int64_t> row_visible(H, 0), row_visible_valid(H, 0), row_valid(H, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, H, 16), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      float* d = res.disparity.ptr<float>(v);
      uint8_t* m = res.valid.ptr<uint8_t>(v);
      if (warped)
        for (int u = 0; u < W; ++u) d[u] = m[u] ? static_cast<float>(d[u] + kappa[v]) : 0.0f;
      int64_t n_valid = 0;
      for (int u = 0; u < W; ++u) {
        if (m[u] && (u - d[u] < 0 || u - d[u] > W - 1)) m[u] = 0, d[u] = 0.0f;
        n_valid += m[u] != 0;
      }
      row_valid[v] = n_valid;
      if (!gpt) continue;
      TransformedDisparityRow(d, m, W, v, res.road, P.gpt_delta_px, res.transformed.ptr<float>(v));
      if (P.gpt_min_valid_fraction <= 0) continue;
      // Visible: the road point u - road(u, v) lies inside the right image.
      const double x_min = res.road.At(0, v), slope = res.road.At(1, v) - x_min;
      int64_t vis = 0, vis_valid = 0;
      for (int u = 0; u < W; ++u)
        if (u - (res.road.quadratic ? res.road.At(u, v) : x_min + slope * u) >= 0) ++vis, vis_valid += m[u] != 0;
      row_visible[v] = vis, row_visible_valid[v] = vis_valid;
    }
  });
  int64_t visible = 0, visible_valid = 0, num_valid = 0;
  for (int v = 0; v < H; ++v) visible += row_visible[v], visible_valid += row_visible_valid[v], num_valid += row_valid[v];
  if (gpt && P.gpt_min_valid_fraction > 0) {
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
  if (gpt) {
    // transformed: filled in the pass above
  } else if (res.road.reliable) {
    res.transformed = TransformedDisparity(res.disparity, res.valid, res.road, P.gpt_delta_px);
  } else {
    res.transformed = cv::Mat::zeros(H, W, CV_32F);
  }
  res.valid_fraction = static_cast<double>(num_valid) / static_cast<double>(res.valid.total());
  res.timings.transform_ms = MsSince(t0);
  res.timings.total_ms = MsSince(t_start);
  return res;
}

}  // namespace rs
