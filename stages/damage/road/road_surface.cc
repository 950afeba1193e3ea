#include "stages/damage/road/road_surface.h"

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>
#if defined(__AVX__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "stages/damage/road/grid_fill.h"
#include "survey/stats/order_statistic.h"
#include "stages/damage/segment/rect_merge.h"
#include "stages/damage/road/relief_smooth.h"
#include "survey/stats/robust_stats.h"

namespace rs {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTukeyC = 4.685;  // 95 % efficiency at the Gaussian

bool ValidDisparity(float d) { return std::isfinite(d) && d > 0; }

// Plane frame from a normal: n towards the camera, e1 along the camera x axis.
void SetFrame(RoadSurface& s, Eigen::Vector3d n, const Eigen::Vector3d& origin) {
  n.normalize();
  if (n.dot(-origin) < 0) n = -n;
  Eigen::Vector3d e1 = Eigen::Vector3d::UnitX() - n * n.x();
  if (e1.norm() < 1e-6) e1 = Eigen::Vector3d::UnitZ() - n * n.z();
  e1.normalize();
  s.normal = n;
  s.e1 = e1;
  s.e2 = n.cross(e1);
  s.origin_m = origin;
  s.camera_height_m = std::abs(n.dot(origin));
}

Eigen::Matrix<double, 6, 1> Monomials(double s, double t) {
  Eigen::Matrix<double, 6, 1> m;
  m << 1, s, t, s * s, s * t, t * t;
  return m;
}

// Four lanes of doubles (GCC/Clang vector extensions): the per-pixel model kernels below
// evaluate four pixels at once, branch-free, with SIMD divisions (which dominate them); the
// same expressions as their one-pixel versions, so the same values.
using V4d = double __attribute__((vector_size(32)));
using V4l = long long __attribute__((vector_size(32)));
using V4f = float __attribute__((vector_size(16)));

inline V4d Abs4(V4d x) { return x < 0 ? -x : x; }  // sign of zero irrelevant: only compared

// x = (u − cx) / f of the pixel ray, for the columns u = u0 .. u0 + n − 1 (one division per
// column instead of per pixel; the same values).
std::vector<double> RayColumns(const RectifiedStereo& g, int u0, int n) {
  std::vector<double> xs(std::max(0, n));
  for (int u = 0; u < n; ++u) xs[u] = (u + u0 - g.cx_px) / g.f_px;
  return xs;
}

}  // namespace

double RoadSurface::DepthBelow(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d r = p - origin_m;
  const double q = coeffs.dot(Monomials(e1.dot(r) / scale_m, e2.dot(r) / scale_m));
  return q - normal.dot(r);
}

double RoadSurface::RayDepth(const RectifiedStereo& g, double u, double v) const {
  // P = Z·ray; s, t, h are affine in Z, so h = q(s, t) is a quadratic in Z.
  const Eigen::Vector3d ray((u - g.cx_px) / g.f_px, (v - g.cy_px) / g.f_px, 1.0);
  const double as = e1.dot(ray) / scale_m, bs = -e1.dot(origin_m) / scale_m;
  const double at = e2.dot(ray) / scale_m, bt = -e2.dot(origin_m) / scale_m;
  const double ah = normal.dot(ray), bh = -normal.dot(origin_m);
  const auto& c = coeffs;
  const double A = -(c[3] * as * as + c[4] * as * at + c[5] * at * at);
  const double B = ah - c[1] * as - c[2] * at - (2 * c[3] * as * bs + c[4] * (as * bt + at * bs) + 2 * c[5] * at * bt);
  const double C = bh - c[0] - c[1] * bs - c[2] * bt - (c[3] * bs * bs + c[4] * bs * bt + c[5] * bt * bt);
  if (std::abs(B) < 1e-12) return kNaN;
  const double z_lin = -C / B;
  if (std::abs(A * z_lin * z_lin) < 1e-9 * std::abs(C) + 1e-15) return z_lin > 0 ? z_lin : kNaN;
  const double disc = B * B - 4 * A * C;
  if (disc < 0) return kNaN;
  const double sq = std::sqrt(disc);
  // Stable roots; keep the one nearest the planar solution (the other is the far branch of the parabola).
  const double qq = -0.5 * (B + (B >= 0 ? sq : -sq));
  const double z1 = qq / A, z2 = C / qq;
  const double z = std::abs(z1 - z_lin) < std::abs(z2 - z_lin) ? z1 : z2;
  return z > 0 ? z : kNaN;
}

namespace {

// The fit's samples: camera points of the valid disparities on a grid of `stride` px.
struct RoadSamples {
  std::vector<Eigen::Vector3d> pts;
  // The sample's cell on the fit grid (pixel / stride), row-major; int, not cv::Point: half the
  // memory, below malloc's mmap threshold (a large block page-faults in the later images).
  std::vector<int> cell;
  int gw = 0, gh = 0;  // grid size
};

RoadSamples SampleRoad(const cv::Mat& disparity_px, const RectifiedStereo& g, int stride) {
  RoadSamples rs;
  rs.gw = (disparity_px.cols + stride - 1) / stride;
  rs.gh = (disparity_px.rows + stride - 1) / stride;
  for (int v = 0; v < disparity_px.rows; v += stride) {
    const float* row = disparity_px.ptr<float>(v);
    for (int u = 0; u < disparity_px.cols; u += stride)
      if (ValidDisparity(row[u])) {
        rs.pts.push_back(CameraPointFromDisparity(g, u, v, row[u]));
        rs.cell.push_back(v / stride * rs.gw + u / stride);
      }
  }
  return rs;
}

// 1. The dominant plane by RANSAC, scored on a fixed random subset (speed), refined by least
// squares through its inliers: the surface's frame, with zero coefficients.
RoadSurface DominantPlane(const std::vector<Eigen::Vector3d>& pts, const RoadModelOptions& o) {
  std::mt19937 rng(o.random_seed);
  std::vector<int> subset;
  {
    std::uniform_int_distribution<int> pick(0, static_cast<int>(pts.size()) - 1);
    const int m = std::min<int>(4000, static_cast<int>(pts.size()));
    for (int i = 0; i < m; ++i) subset.push_back(pick(rng));
  }
  std::uniform_int_distribution<int> pick(0, static_cast<int>(pts.size()) - 1);
  Eigen::Vector3d best_n = -Eigen::Vector3d::UnitY();
  double best_c = 0;
  int best_score = -1;
  // Samples drawn in sequence (the same random stream), hypotheses scored in parallel, the best
  // taken in iteration order (first of equal scores): the same plane as a serial loop.
  std::vector<std::array<int, 3>> draws(o.ransac_iterations);
  for (auto& d : draws)
    for (int& k : d) k = pick(rng);
  std::vector<Eigen::Vector3d> hyp_n(draws.size());
  std::vector<double> hyp_c(draws.size());
  std::vector<int> hyp_score(draws.size(), -2);  // -2: degenerate sample, skipped
  tbb::parallel_for(0, static_cast<int>(draws.size()), [&](int it) {
    const Eigen::Vector3d &a = pts[draws[it][0]], &b = pts[draws[it][1]], &c = pts[draws[it][2]];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-12) return;
    n.normalize();
    const double off = n.dot(a);
    int score = 0;
    for (int i : subset) score += std::abs(n.dot(pts[i]) - off) < o.ransac_inlier_m;
    hyp_n[it] = n, hyp_c[it] = off, hyp_score[it] = score;
  });
  for (size_t it = 0; it < draws.size(); ++it)
    if (hyp_score[it] > -2 && hyp_score[it] > best_score)
      best_score = hyp_score[it], best_n = hyp_n[it], best_c = hyp_c[it];
  // Least-squares plane through the RANSAC inliers.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::vector<int> inl;
  for (size_t i = 0; i < pts.size(); ++i)
    if (std::abs(best_n.dot(pts[i]) - best_c) < o.ransac_inlier_m) inl.push_back(static_cast<int>(i));
  if (inl.size() < 10) throw std::invalid_argument("road surface: no dominant road plane found");
  for (int i : inl) centroid += pts[i];
  centroid /= static_cast<double>(inl.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i : inl) cov += (pts[i] - centroid) * (pts[i] - centroid).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  RoadSurface s;
  SetFrame(s, es.eigenvectors().col(0), centroid);
  double spread = 0;
  for (int i : inl) spread += (pts[i] - centroid).squaredNorm();
  s.scale_m = std::max(1e-3, std::sqrt(spread / static_cast<double>(inl.size())));
  s.points_used = static_cast<int>(pts.size());
  return s;
}

// 2. Obstacles first (far above the current model), then the Tukey-IRLS quadratic; twice, so a
//    curved road is judged against the curved model, not the plane.
class QuadraticRoadFit {
 public:
  QuadraticRoadFit(const std::vector<Eigen::Vector3d>& pts, RoadSurface& s, const RoadModelOptions& o)
      : s_(s),
        o_(o),
        mono(pts.size()),
        h(pts.size()),
        obstacle(pts.size(), 0),
        w(pts.size(), 1.0),
        res(pts.size()),
        sigma(o.min_noise_m) {
    // The monomials of each sample's plane coordinates, computed once for every IRLS pass (built
    // in a temporary each time, they went through the stack: store-forwarding stalls).
    for (size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector3d r = pts[i] - s.origin_m;
      mono[i] = Monomials(s.e1.dot(r) / s.scale_m, s.e2.dot(r) / s.scale_m);
      h[i] = s.normal.dot(r);
    }
    absr.reserve(pts.size());
  }

  // Fits s_.coeffs; `offroad` samples take no part in the fit (they are not flagged obstacles).
  void Fit(const std::vector<char>& offroad, bool whole_region) {
    s_.coeffs.setZero();
    for (int round = 0; round < 2; ++round) {
      StartRound(offroad, whole_region, round);
      for (int it = 0; it < o_.irls_iterations; ++it) IrlsStep(offroad, round);
    }
  }

  double Residual(size_t i) const { return h[i] - s_.coeffs.dot(mono[i]); }

 private:
  // Start each round from the band inliers: damage and obstacles start with zero weight. The
  // first round starts wider, so both lanes of a crowned (roof-shaped) road take part even
  // when RANSAC's plane followed one of them.
  void StartRound(const std::vector<char>& offroad, bool whole_region, int round) {
    for (size_t i = 0; i < h.size(); ++i) {
      res[i] = h[i] - s_.coeffs.dot(mono[i]);
      obstacle[i] = res[i] > o_.obstacle_height_m;
      const double band = round == 0 ? (whole_region ? kInf : 2.0 * o_.ransac_inlier_m) : o_.ransac_inlier_m;
      w[i] = !obstacle[i] && !offroad[i] && std::abs(res[i]) < band ? 1.0 : 0.0;
    }
  }

  void IrlsStep(const std::vector<char>& offroad, int round) {
    Eigen::Matrix<double, 6, 6> AtA = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> Atb = Eigen::Matrix<double, 6, 1>::Zero();
    for (size_t i = 0; i < h.size(); ++i) {
      if (w[i] <= 0) continue;
      const auto& m = mono[i];
      // AtA.selfadjointView<Lower>().rankUpdate(m, w[i]), written out: Eigen's is an
      // out-of-line call per sample (the same operations: column j += (w·m_j)·m_j..5).
      double* a = AtA.data();
      for (int j = 0; j < 6; ++j) {
        const double wm = w[i] * m[j];
        for (int k = j; k < 6; ++k) a[6 * j + k] += wm * m[k];
      }
      Atb += w[i] * h[i] * m;
    }
    AtA = AtA.selfadjointView<Eigen::Lower>();
    s_.coeffs = AtA.ldlt().solve(Atb);
    absr.clear();
    for (size_t i = 0; i < h.size(); ++i) {
      res[i] = h[i] - s_.coeffs.dot(mono[i]);
      if (!obstacle[i] && w[i] > 0) absr.push_back(std::abs(res[i]));
    }
    // First round: scale floored at the plane band (a wide Tukey window, graduated
    // non-convexity); the second round shrinks to the data's own spread.
    sigma = std::max(round == 0 ? o_.ransac_inlier_m : o_.min_noise_m, absr.empty() ? kNaN : RobustSigmaOfAbs(absr));
    for (size_t i = 0; i < h.size(); ++i) {
      if (obstacle[i] || offroad[i]) {
        w[i] = 0;
        continue;
      }
      const double x = res[i] / (kTukeyC * sigma);
      w[i] = std::abs(x) < 1 ? (1 - x * x) * (1 - x * x) : 0.0;
    }
  }

  RoadSurface& s_;
  const RoadModelOptions& o_;

 public:
  std::vector<Eigen::Matrix<double, 6, 1>> mono;
  std::vector<double> h;
  std::vector<char> obstacle;
  std::vector<double> w, res;
  double sigma;
  std::vector<double> absr;  // one buffer for every IRLS pass (a fresh one page-faults)
};

// 3. Road regions cut off from the main one by obstacles: beside a car parked at the kerb, the
//    raised pavement beyond it is such a region, and the road between it and the car is hidden,
//    so the quadratic bent up to the pavement. Fit the largest region alone, then let the others
//    back only where they agree with it.
void RefitMainRegion(const RoadSamples& rs, QuadraticRoadFit& fit, std::vector<char>& offroad,
                     const RoadModelOptions& o) {
  const std::vector<Eigen::Vector3d>& pts = rs.pts;
  const std::vector<int>& cell = rs.cell;
  const int gw = rs.gw;
  // Grid of residuals about the first fit; a jump of more than the obstacle height between
  // neighbouring samples (a kerb face) separates regions like an obstacle does.
  cv::Mat road_cells(rs.gh, gw, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (size_t i = 0; i < pts.size(); ++i)
    if (!fit.obstacle[i]) road_cells.at<float>(cell[i] / gw, cell[i] % gw) = static_cast<float>(fit.res[i]);
  int n_labels = 0;
  const cv::Mat labels = LabelSmoothRegions(road_cells, static_cast<float>(o.obstacle_height_m), &n_labels);
  const int n_regions = n_labels + 1;  // with the empty label 0
  std::vector<int> area(n_regions, 0);
  std::vector<double> weight(n_regions, 0.0);
  for (size_t i = 0; i < pts.size(); ++i)
    if (!fit.obstacle[i])
      ++area[labels.at<int>(cell[i] / gw, cell[i] % gw)],
          weight[labels.at<int>(cell[i] / gw, cell[i] % gw)] += fit.w[i];
  int main_region = 1;
  for (int k = 2; k < n_regions; ++k)
    if (area[k] > area[main_region]) main_region = k;
  // Only regions that took part in the fit can have bent it (a pothole's floor, cut off by its
  // walls, had no weight): otherwise the fit stands, and no time is spent.
  const double total_weight = std::accumulate(weight.begin(), weight.end(), 0.0);
  if (!(n_regions > 2 && total_weight - weight[main_region] > 0.01 * total_weight)) return;
  std::vector<int> region(pts.size(), 0);
  for (size_t i = 0; i < pts.size(); ++i) {
    region[i] = fit.obstacle[i] ? 0 : labels.at<int>(cell[i] / gw, cell[i] % gw);
    offroad[i] = region[i] != 0 && region[i] != main_region;
  }
  fit.Fit(offroad, true);
  // A region rejoins when its median height about the main region's surface is within the
  // plane band (it is the same road seen past an obstacle).
  std::vector<std::vector<double>> r_of(n_regions);
  for (size_t i = 0; i < pts.size(); ++i)
    if (offroad[i]) r_of[region[i]].push_back(fit.Residual(i));
  bool rejoined = false;
  for (int k = 1; k < n_regions; ++k)
    if (!r_of[k].empty() && std::abs(LowerMedianInPlace(r_of[k])) < o.ransac_inlier_m) {
      rejoined = true;
      for (size_t i = 0; i < pts.size(); ++i)
        if (region[i] == k) offroad[i] = 0;
    }
  if (rejoined) fit.Fit(offroad, true);
}

}  // namespace

RoadSurface FitRoadSurface(const cv::Mat& disparity_px, const RectifiedStereo& g, const RoadModelOptions& o) {
  if (!g.Valid()) throw std::invalid_argument("road surface: stereo geometry needs f > 0 and baseline > 0");
  if (disparity_px.type() != CV_32FC1) throw std::invalid_argument("road surface: disparity must be CV_32FC1");
  const RoadSamples samples = SampleRoad(disparity_px, g, o.fit_stride_px);
  if (samples.pts.size() < 50) throw std::invalid_argument("road surface: fewer than 50 valid disparities to fit");
  RoadSurface s = DominantPlane(samples.pts, o);
  QuadraticRoadFit fit(samples.pts, s, o);
  std::vector<char> offroad(samples.pts.size(), 0);
  fit.Fit(offroad, false);
  RefitMainRegion(samples, fit, offroad, o);
  s.residual_sigma_m = fit.sigma;
  s.inliers = static_cast<int>(std::count_if(fit.w.begin(), fit.w.end(), [](double x) { return x > 0; }));
  s.obstacle_points = static_cast<int>(std::count(fit.obstacle.begin(), fit.obstacle.end(), 1));
  return s;
}

namespace {

// Per-cell median of depth below the model (mm) over pixels not in `ignore` (obstacles, known
// damage) from `band_mm` below `prior` (full-resolution CV_32F; empty = 0) to `above_mm` above it;
// cells with too few such pixels are filled from their neighbours.
// Returns the (gh × gw) grid, 3×3 smoothed; UpsampleGrid interpolates it to full resolution.
cv::Mat CellGrid(const cv::Mat& depth, const cv::Mat& ignore, const cv::Mat& prior, double band_mm, int cell,
                 double above_mm) {
  const int gw = (depth.cols + cell - 1) / cell, gh = (depth.rows + cell - 1) / cell;
  cv::Mat grid(gh, gw, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  // Every third pixel in u and v: 64 samples per 24-px cell are plenty for a median.
  tbb::parallel_for(0, gh, [&](int gy) {  // one grid row per task
    std::vector<float> vals;
    for (int gx = 0; gx < gw; ++gx) {
      vals.clear();
      int seen = 0;
      const int u0 = gx * cell, u1 = std::min((gx + 1) * cell, depth.cols);
      for (int v = gy * cell; v < std::min((gy + 1) * cell, depth.rows); v += 3) {
        const float* x = depth.ptr<float>(v);
        const float* p = prior.empty() ? nullptr : prior.ptr<float>(v);
        const uchar* ob = ignore.ptr<uchar>(v);
        for (int u = u0; u < u1; u += 3) {
          ++seen;
          if (ob[u] || !std::isfinite(x[u])) continue;
          const float e = x[u] - (p ? p[u] : 0.0f);
          if (e < band_mm && -e < above_mm) vals.push_back(x[u]);
        }
      }
      if (vals.size() * 2 < static_cast<size_t>(seen) || vals.empty()) continue;
      grid.at<float>(gy, gx) = LowerMedianInPlace(vals);
    }
  });
  // Fill empty cells (damage, obstacles, no disparity) from their neighbours, ring by ring.
  FillEmptyCellsFromNeighbours(&grid);
  cv::patchNaNs(grid, 0.0);
  cv::blur(grid, grid, {3, 3}, {-1, -1}, cv::BORDER_REPLICATE);
  return grid;
}

// Bilinear interpolation of a cell grid to the image size. Grid node j only influences pixels
// in [(j − 1)·cell, (j + 2)·cell).
cv::Mat UpsampleGrid(const cv::Mat& grid, int cell, cv::Size size) {
  cv::Mat full;
  cv::resize(grid, full, {grid.cols * cell, grid.rows * cell}, 0, 0, cv::INTER_LINEAR);
  return full(cv::Rect({}, size));  // a view: no copy
}

// Robust spread (1.4826 · median |residual|, mm) of the depth below the model after `corr`
// outside `ignore`.
double ResidualSpreadMm(const cv::Mat& depth, const cv::Mat& ignore, const cv::Mat& corr) {
  std::vector<float> e;
  for (int v = 0; v < corr.rows; v += 4) {
    const float* x = depth.ptr<float>(v);
    const float* c = corr.ptr<float>(v);
    const uchar* ob = ignore.ptr<uchar>(v);
    for (int u = 0; u < corr.cols; u += 4)
      if (!ob[u] && std::isfinite(x[u])) e.push_back(std::abs(x[u] - c[u]));
  }
  return e.empty() ? 0 : RobustSigmaOfAbs(e);
}

// Local correction (mm) of the depth below the model `depth` (uncorrected), leaving out
// obstacles and `exclude`: grid and full resolution.
struct LocalCorrection {
  cv::Mat grid, full;
};
LocalCorrection ComputeLocalCorrection(const cv::Mat& depth, const cv::Mat& obstacle, const cv::Mat& exclude,
                                       const RoadSurface& s, const RoadModelOptions& o) {
  // Known damage is left out of the cell medians like an obstacle.
  const cv::Mat ignore = exclude.empty() ? obstacle : (obstacle | exclude);
  const int cell = o.local_cell_px;
  const double band1 = std::clamp(4000.0 * s.residual_sigma_m, 6.0, 20.0);
  // Above the model the band reaches the obstacle height: damage lies only below the road, and a
  // road rising off the quadratic (a verge before the kerb) is road; cut at ±band1, cells on the
  // rise would take their neighbours' correction and the reference beside a pothole there would
  // lie too low.
  const double above1 = std::max(band1, 1000.0 * o.obstacle_height_m);
  const cv::Mat c1 = UpsampleGrid(CellGrid(depth, ignore, cv::Mat(), band1, cell, above1), cell, depth.size());
  // The band's spread is taken over all road pixels, known damage included (MAD: robust to it),
  // so a refinement with other exclusions changes the correction only around them.
  const double band2 = std::max(3.0 * ResidualSpreadMm(depth, obstacle, c1), 1000.0 * o.min_noise_m * 2.0);
  LocalCorrection c;
  c.grid = CellGrid(depth, ignore, c1, band2, cell, band2);
  c.full = UpsampleGrid(c.grid, cell, depth.size());
  return c;
}

// Applies the correction `corr` to the uncorrected relief `r`, whose pixel (0, 0) is image
// pixel `at` (r, disparity_px and corr all of one size).
// One pixel of ApplyCorrection (x, y: the ray's (u − cx)/f, (v − cy)/f; n: the plane normal).
inline void CorrectPixel(double x, double y, double nx, double ny, double nz, double fb, double delta, float c, float d,
                         uchar valid, float* td, float* db, float* rz) {
  if (!std::isfinite(*rz)) return;
  // Height of Z·ray above the plane changes by (n·ray) per metre of Z: lowering the road
  // by c moves its ray intersection ΔZ = −c / (n·ray) further.
  const double nr = nx * x + ny * y + nz;
  if (std::abs(nr) < 1e-6) return;
  const double dz = -1e-3 * c / nr;
  if (!(*rz + dz > 0)) return;
  *rz = static_cast<float>(*rz + dz);
  if (!valid) return;
  *db -= c;
  *td = static_cast<float>(std::max(1e-3, d - fb / *rz + delta));
}

// Four pixels of CorrectPixel at once, branch-free with per-lane selects (bit-identical).
void CorrectPixels4(const double* xs, double y, double nx, double ny, double nz, double fb, double delta,
                    const float* c, const float* d, const uchar* valid, float* td, float* db, float* rz) {
  V4d x;
  std::memcpy(&x, xs, sizeof x);
  V4f cf, df, rzf;
  std::memcpy(&cf, c, sizeof cf);
  std::memcpy(&df, d, sizeof df);
  std::memcpy(&rzf, rz, sizeof rzf);
  const V4d cd = __builtin_convertvector(cf, V4d), dd = __builtin_convertvector(df, V4d);
  const V4d rzd = __builtin_convertvector(rzf, V4d);
  const V4d nr = nx * x + ny * y + nz;
  const V4d dz = -1e-3 * cd / nr;
  const V4d sum = rzd + dz;
  const V4l move = (Abs4(rzd) <= std::numeric_limits<double>::max()) & (Abs4(nr) >= 1e-6) & (sum > 0);
  V4f moved;
  for (int i = 0; i < 4; ++i) moved[i] = static_cast<float>(sum[i]);
  const V4d t = dd - fb / __builtin_convertvector(moved, V4d) + delta;
  const V4d tc = 1e-3 < t ? t : 1e-3;
  for (int i = 0; i < 4; ++i) {
    if (!move[i]) continue;
    rz[i] = moved[i];
    if (!valid[i]) continue;
    db[i] -= c[i];
    td[i] = static_cast<float>(tc[i]);
  }
}

// Applies the correction `corr` to the uncorrected relief `r`, whose pixel (0, 0) is image
// pixel `at` (r, disparity_px and corr all of one size). With `from`, the uncorrected transformed
// disparity, depth and road depth are read from there and written to new images of `r` (row by
// row, while in cache: no separate copy of the frame); `r` needs only its masks then.
void ApplyCorrection(RoadRelief& r, const cv::Mat& corr, const cv::Mat& disparity_px, cv::Point at,
                     const RectifiedStereo& g, const RoadSurface& s, const RoadModelOptions& o,
                     const RoadRelief* from = nullptr) {
  r.correction_mm = corr;
  if (from) {
    r.transformed_disparity_px.create(corr.size(), CV_32F);
    r.depth_below_mm.create(corr.size(), CV_32F);
    r.road_depth_m.create(corr.size(), CV_32F);
  }
  const double fb = g.f_px * g.baseline_m, delta = o.delta_px;
  const double nx = s.normal.x(), ny = s.normal.y(), nz = s.normal.z();
  const std::vector<double> xs = RayColumns(g, at.x, corr.cols);  // one division per column
  tbb::parallel_for(0, corr.rows, [&](int v) {
    const float* c = corr.ptr<float>(v);
    const float* d = disparity_px.ptr<float>(v);
    float* td = r.transformed_disparity_px.ptr<float>(v);
    float* db = r.depth_below_mm.ptr<float>(v);
    float* rz = r.road_depth_m.ptr<float>(v);
    const uchar* va = r.valid_mask.ptr<uchar>(v);
    const double y = (v + at.y - g.cy_px) / g.f_px;
    if (from) {
      const size_t bytes = corr.cols * sizeof(float);
      std::memcpy(td, from->transformed_disparity_px.ptr<float>(v), bytes);
      std::memcpy(db, from->depth_below_mm.ptr<float>(v), bytes);
      std::memcpy(rz, from->road_depth_m.ptr<float>(v), bytes);
    }
    int u = 0;
    for (; u + 4 <= corr.cols; u += 4)
      CorrectPixels4(&xs[u], y, nx, ny, nz, fb, delta, c + u, d + u, va + u, td + u, db + u, rz + u);
    for (; u < corr.cols; ++u) CorrectPixel(xs[u], y, nx, ny, nz, fb, delta, c[u], d[u], va[u], td + u, db + u, rz + u);
  });
}

// The relief smoothing's window per image row (relief_smooth.h).
std::vector<cv::Size> SmoothWindows(int rows, const RectifiedStereo& g, const RoadSurface& s,
                                    const RoadModelOptions& o) {
  return ReliefSmoothWindows(rows, g, s.normal, o.relief_smooth_px, o.relief_smooth_ground);
}

}  // namespace

namespace {

// The quadratic model's per-frame constants for EvaluateRect: s, t, h of P = Z·ray are
// Z·(k·ray) + b with ray = ((u − cx)/f, (v − cy)/f, 1). Plain locals: read through the
// RoadSurface, the compiler reloads them after every store (possible aliasing).
struct ModelConstants {
  double c[6];
  double ksx, ksy, ksz, ktx, kty, ktz, khx, khy, khz, bs, bt, bh;
  double fb, obstacle_m, delta;
};

// One pixel of EvaluateRect: x = (u − cx)/f, y = (v − cy)/f; writes the five outputs.
inline void EvaluatePixel(const ModelConstants& k, double x, double y, float d, float* td, float* db, float* rz,
                          uchar* ob, uchar* va) {
  const double* c = k.c;
  const double bs = k.bs, bt = k.bt, bh = k.bh;
  const double as = k.ksx * x + k.ksy * y + k.ksz, at = k.ktx * x + k.kty * y + k.ktz;
  const double ah = k.khx * x + k.khy * y + k.khz;
  // Road: h(Z) = q(s(Z), t(Z)), a quadratic A Z² + B Z + C = 0 (as RoadSurface::RayDepth).
  const double A = -(c[3] * as * as + c[4] * as * at + c[5] * at * at);
  const double B = ah - c[1] * as - c[2] * at - (2 * c[3] * as * bs + c[4] * (as * bt + at * bs) + 2 * c[5] * at * bt);
  const double C = bh - c[0] - c[1] * bs - c[2] * bt - (c[3] * bs * bs + c[4] * bs * bt + c[5] * bt * bt);
  double z_road = std::numeric_limits<double>::quiet_NaN();
  if (std::abs(B) > 1e-12) {
    const double z_lin = -C / B;
    if (std::abs(A * z_lin * z_lin) < 1e-9 * std::abs(C) + 1e-15) {
      z_road = z_lin;
    } else {
      const double disc = B * B - 4 * A * C;
      if (disc >= 0) {
        const double sq = std::sqrt(disc), qq = -0.5 * (B + (B >= 0 ? sq : -sq));
        const double z1 = qq / A, z2 = C / qq;
        z_road = std::abs(z1 - z_lin) < std::abs(z2 - z_lin) ? z1 : z2;
      }
    }
    if (!(z_road > 0)) z_road = std::numeric_limits<double>::quiet_NaN();
  }
  *rz = static_cast<float>(z_road);
  // A ray that misses the road (above the horizon) has no relief.
  const bool ok = ValidDisparity(d) && std::isfinite(z_road);
  *va = ok ? 255 : 0;
  if (!ok) {
    *td = 0;
    *db = std::numeric_limits<float>::quiet_NaN();
    *ob = 0;
    return;
  }
  const double z = k.fb / d;
  const double ps = z * as + bs, pt = z * at + bt, ph = z * ah + bh;
  const double below = c[0] + c[1] * ps + c[2] * pt + c[3] * ps * ps + c[4] * ps * pt + c[5] * pt * pt - ph;
  *db = static_cast<float>(below * 1000.0);
  *ob = -below > k.obstacle_m ? 255 : 0;
  // Keep invalid = 0 distinguishable from a very deep pixel: clamp valid values to a tiny positive.
  *td = static_cast<float>(std::max(1e-3, d - k.fb / z_road + k.delta));
}

// Four pixels of EvaluatePixel at once, branch-free with per-lane selects (bit-identical).

void EvaluatePixels4(const ModelConstants& k, const double* xs, double y, const float* d, float* td, float* db,
                     float* rz, uchar* ob, uchar* va) {
  const double* c = k.c;
  const double bs = k.bs, bt = k.bt, bh = k.bh;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  V4d x;
  std::memcpy(&x, xs, sizeof x);
  const V4d as = k.ksx * x + k.ksy * y + k.ksz, at = k.ktx * x + k.kty * y + k.ktz;
  const V4d ah = k.khx * x + k.khy * y + k.khz;
  const V4d A = -(c[3] * as * as + c[4] * as * at + c[5] * at * at);
  const V4d B = ah - c[1] * as - c[2] * at - (2 * c[3] * as * bs + c[4] * (as * bt + at * bs) + 2 * c[5] * at * bt);
  const double C = bh - c[0] - c[1] * bs - c[2] * bt - (c[3] * bs * bs + c[4] * bs * bt + c[5] * bt * bt);
  const V4d z_lin = -C / B;
  const V4l lin = Abs4(A * z_lin * z_lin) < 1e-9 * std::abs(C) + 1e-15;
  const V4d disc = B * B - 4 * A * C;
  V4d sq;
#if defined(__AVX__)
  // One vector square root (IEEE, correctly rounded: the scalar one's values); lanes with
  // disc < 0 or NaN take sqrt(0) = 0, as the scalar loop's 0.
  sq = reinterpret_cast<V4d>(_mm256_sqrt_pd(reinterpret_cast<__m256d>(disc >= 0 ? disc : 0.0)));
#else
  for (int i = 0; i < 4; ++i) sq[i] = disc[i] >= 0 ? std::sqrt(disc[i]) : 0.0;
#endif
  const V4d qq = -0.5 * (B + (B >= 0 ? sq : -sq));
  const V4d z1 = qq / A, z2 = C / qq;
  const V4d zq = Abs4(z1 - z_lin) < Abs4(z2 - z_lin) ? z1 : z2;
  V4d z_road = lin ? z_lin : (disc >= 0 ? zq : nan);
  z_road = (Abs4(B) > 1e-12) & (z_road > 0) ? z_road : nan;
  V4f df;
  std::memcpy(&df, d, sizeof df);
  const V4d dd = __builtin_convertvector(df, V4d);
  const double dmax = std::numeric_limits<double>::max();
  const V4l ok = (Abs4(dd) <= dmax) & (dd > 0) & (Abs4(z_road) <= dmax);
  const V4d z = k.fb / dd;
  const V4d ps = z * as + bs, pt = z * at + bt, ph = z * ah + bh;
  const V4d below = c[0] + c[1] * ps + c[2] * pt + c[3] * ps * ps + c[4] * ps * pt + c[5] * pt * pt - ph;
  const V4d below_mm = below * 1000.0;
  const V4d t = dd - k.fb / z_road + k.delta;
  const V4d tc = 1e-3 < t ? t : 1e-3;
  const V4l obstacle = -below > k.obstacle_m;
  for (int i = 0; i < 4; ++i) {
    rz[i] = static_cast<float>(z_road[i]);
    va[i] = ok[i] ? 255 : 0;
    td[i] = ok[i] ? static_cast<float>(tc[i]) : 0.0f;
    db[i] = ok[i] ? static_cast<float>(below_mm[i]) : std::numeric_limits<float>::quiet_NaN();
    ob[i] = ok[i] && obstacle[i] ? 255 : 0;
  }
}

// The quadratic model evaluated on the pixels of `roi` (the relief's pixel (0, 0) is roi.tl()).
RoadRelief EvaluateRect(const cv::Mat& disparity_px, const RectifiedStereo& g, const RoadSurface& s,
                        const RoadModelOptions& o, const cv::Rect& roi) {
  RoadRelief r;
  const cv::Size size = roi.size();
  r.transformed_disparity_px.create(size, CV_32F);
  r.depth_below_mm.create(size, CV_32F);
  r.road_depth_m.create(size, CV_32F);
  r.obstacle_mask.create(size, CV_8U);
  r.valid_mask.create(size, CV_8U);
  const double L = s.scale_m;
  const Eigen::Vector3d ks = s.e1 / L, kt = s.e2 / L, kh = s.normal;
  ModelConstants k;
  for (int i = 0; i < 6; ++i) k.c[i] = s.coeffs[i];
  k.ksx = ks.x(), k.ksy = ks.y(), k.ksz = ks.z(), k.ktx = kt.x(), k.kty = kt.y(), k.ktz = kt.z();
  k.khx = kh.x(), k.khy = kh.y(), k.khz = kh.z();
  k.bs = -ks.dot(s.origin_m), k.bt = -kt.dot(s.origin_m), k.bh = -kh.dot(s.origin_m);
  k.fb = g.f_px * g.baseline_m, k.obstacle_m = o.obstacle_height_m, k.delta = o.delta_px;
  const std::vector<double> xs = RayColumns(g, roi.x, size.width);  // one division per column
  tbb::parallel_for(0, size.height, [&](int v) {
    const float* d = disparity_px.ptr<float>(v + roi.y) + roi.x;
    float* td = r.transformed_disparity_px.ptr<float>(v);
    float* db = r.depth_below_mm.ptr<float>(v);
    float* rz = r.road_depth_m.ptr<float>(v);
    uchar* ob = r.obstacle_mask.ptr<uchar>(v);
    uchar* va = r.valid_mask.ptr<uchar>(v);
    const double y = (v + roi.y - g.cy_px) / g.f_px;
    int u = 0;
    for (; u + 4 <= size.width; u += 4) EvaluatePixels4(k, &xs[u], y, d + u, td + u, db + u, rz + u, ob + u, va + u);
    for (; u < size.width; ++u) EvaluatePixel(k, xs[u], y, d[u], td + u, db + u, rz + u, ob + u, va + u);
  });
  return r;  // correction_mm: set by FinishRoadRelief (zeros when the local correction is off)
}

}  // namespace

RoadRelief EvaluateRoadModel(const cv::Mat& disparity_px, const RectifiedStereo& g, const RoadSurface& s,
                             const RoadModelOptions& o) {
  if (!g.Valid()) throw std::invalid_argument("road relief: stereo geometry needs f > 0 and baseline > 0");
  if (disparity_px.type() != CV_32FC1) throw std::invalid_argument("road relief: disparity must be CV_32FC1");
  return EvaluateRect(disparity_px, g, s, o, cv::Rect({}, disparity_px.size()));
}

RoadRelief FinishRoadRelief(const RoadRelief& evaluated, const cv::Mat& disparity_px, const RectifiedStereo& g,
                            const RoadSurface& s, const RoadModelOptions& o, const cv::Mat& exclude) {
  if (!exclude.empty() && (exclude.type() != CV_8UC1 || exclude.size() != disparity_px.size()))
    throw std::invalid_argument("road relief: exclude mask must be CV_8U of the disparity's size");
  if (evaluated.depth_below_mm.size() != disparity_px.size())
    throw std::invalid_argument("road relief: evaluated model and disparity differ in size");
  RoadRelief r;  // the masks shared with `evaluated`, new images for the rest
  r.obstacle_mask = evaluated.obstacle_mask;
  r.valid_mask = evaluated.valid_mask;
  if (o.local_cell_px > 0) {
    const LocalCorrection c = ComputeLocalCorrection(evaluated.depth_below_mm, r.obstacle_mask, exclude, s, o);
    ApplyCorrection(r, c.full, disparity_px, {0, 0}, g, s, o, &evaluated);
    r.correction_grid_mm = c.grid;
  } else {
    r.transformed_disparity_px = evaluated.transformed_disparity_px.clone();
    r.depth_below_mm = evaluated.depth_below_mm.clone();
    r.road_depth_m = evaluated.road_depth_m.clone();
    r.correction_mm = cv::Mat::zeros(r.depth_below_mm.size(), CV_32F);
  }
  if (o.relief_smooth_px > 1)
    r.smooth_noise_px =
        SmoothReliefRows(r, SmoothWindows(r.depth_below_mm.rows, g, s, o), 0, o.relief_smooth_edge_sigma);
  return r;
}

void RefineRoadRelief(RoadRelief& r, const RoadRelief& evaluated, const cv::Mat& disparity_px, const RectifiedStereo& g,
                      const RoadSurface& s, const RoadModelOptions& o, const cv::Mat& exclude) {
  if (o.local_cell_px <= 0) return;
  if (evaluated.depth_below_mm.size() != disparity_px.size() || r.correction_grid_mm.empty() ||
      (!exclude.empty() && (exclude.type() != CV_8UC1 || exclude.size() != disparity_px.size())))
    throw std::invalid_argument(
        "RefineRoadRelief: needs a FinishRoadRelief result, its evaluation and masks of its size");
  const LocalCorrection c = ComputeLocalCorrection(evaluated.depth_below_mm, r.obstacle_mask, exclude, s, o);
  // Only pixels whose interpolation stencil holds a changed grid node change; each such region
  // is corrected again from the evaluation and smoothed with a margin of the smoothing window,
  // and its inner part copied back: the same values as a full recomputation.
  const cv::Mat changed = c.grid != r.correction_grid_mm;
  cv::Mat cc, stats, centroids;
  const int n = cv::connectedComponentsWithStats(changed, cc, stats, centroids, 8, CV_32S);
  const std::vector<cv::Size> windows = SmoothWindows(disparity_px.rows, g, s, o);
  int m = 1;  // margin: half the largest smoothing window, plus one
  for (const cv::Size& k : windows) m = std::max(m, std::max(k.width, k.height) / 2 + 1);
  const int cell = o.local_cell_px;
  const cv::Rect frame({}, disparity_px.size());
  std::vector<cv::Rect> regions;
  for (int i = 1; i < n; ++i) {
    const int gx = stats.at<int>(i, cv::CC_STAT_LEFT), gy = stats.at<int>(i, cv::CC_STAT_TOP);
    const int gw = stats.at<int>(i, cv::CC_STAT_WIDTH), gh = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    regions.push_back(cv::Rect((gx - 1) * cell, (gy - 1) * cell, (gw + 2) * cell, (gh + 2) * cell) & frame);
  }
  MergeOverlappingRects(&regions);  // no pixel done twice
  for (const cv::Rect& inner : regions) {
    const cv::Rect outer = cv::Rect(inner.x - m, inner.y - m, inner.width + 2 * m, inner.height + 2 * m) & frame;
    RoadRelief from, sub;  // the region of the evaluation (views), its corrected copy
    from.transformed_disparity_px = evaluated.transformed_disparity_px(outer);
    from.depth_below_mm = evaluated.depth_below_mm(outer);
    from.road_depth_m = evaluated.road_depth_m(outer);
    sub.valid_mask = evaluated.valid_mask(outer);
    sub.obstacle_mask = evaluated.obstacle_mask(outer);
    ApplyCorrection(sub, c.full(outer), disparity_px(outer), outer.tl(), g, s, o, &from);
    if (o.relief_smooth_px > 1) SmoothReliefRows(sub, windows, outer.y, o.relief_smooth_edge_sigma, r.smooth_noise_px);
    const cv::Rect in_sub(inner.tl() - outer.tl(), inner.size());
    sub.transformed_disparity_px(in_sub).copyTo(r.transformed_disparity_px(inner));
    sub.depth_below_mm(in_sub).copyTo(r.depth_below_mm(inner));
    sub.road_depth_m(in_sub).copyTo(r.road_depth_m(inner));
  }
  r.correction_mm = c.full;
  r.correction_grid_mm = c.grid;
}

RoadRelief ComputeRoadRelief(const cv::Mat& disparity_px, const RectifiedStereo& g, const RoadSurface& s,
                             const RoadModelOptions& o, const cv::Mat& exclude) {
  return FinishRoadRelief(EvaluateRoadModel(disparity_px, g, s, o), disparity_px, g, s, o, exclude);
}

}  // namespace rs
