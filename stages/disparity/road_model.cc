#include "stages/disparity/road_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_invoke.h>

namespace rs {

double RoadModel::At(double u, double v) const {
  return c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v;
}

void RoadModel::SetRoll(double a0_px, double a1_px, double roll) {
  a0 = a0_px, a1 = a1_px, roll_rad = roll;
  c = {a0, -a1 * std::sin(roll), a1 * std::cos(roll), 0, 0, 0};
  quadratic = false;
}

double RoadModel::RowMin(double v, int width) const {
  const double x_max = std::max(0, width - 1);
  double m = std::min(At(0, v), At(x_max, v));
  if (quadratic && c[3] > 0) {  // interior vertex of the parabola in u
    const double x = -(c[1] + c[4] * v) / (2 * c[3]);
    if (x > 0 && x < x_max) m = std::min(m, At(x, v));
  }
  return m;
}

void RoadModel::SetPlane(double c0, double cu, double cv) {
  // a1 cos(phi) = cv, -a1 sin(phi) = cu, with cos(phi) > 0 picking one of the two solutions.
  a0 = c0;
  const double h = std::hypot(cu, cv);
  if (h == 0) {
    a1 = 0, roll_rad = 0;
  } else if (cv >= 0) {
    a1 = h, roll_rad = std::atan2(-cu, cv);
  } else {
    a1 = -h, roll_rad = std::atan2(cu, -cv);
  }
  c = {c0, cu, cv, 0, 0, 0};
  quadratic = false;
}

void RoadFitOptions::Check() const {
  auto fail = [](const std::string& m) { throw std::invalid_argument("road_model: " + m); };
  if (max_features < 10) fail("max_features = " + std::to_string(max_features) + " violates max_features >= 10");
  if (fast_threshold < 1) fail("fast_threshold = " + std::to_string(fast_threshold) + " violates fast_threshold >= 1");
  if (!(detect_scale > 0 && detect_scale <= 1)) fail("detect_scale violates 0 < detect_scale <= 1");
  if (!(max_row_diff_px >= 0)) fail("max_row_diff_px violates max_row_diff_px >= 0");
  if (!(max_disparity_px == 0 || max_disparity_px > min_disparity_px) || !(min_disparity_px >= 0))
    fail("disparity bounds violate 0 <= min_disparity_px < max_disparity_px (or max_disparity_px = 0: up to the "
         "image width)");
  if (!(ratio > 0 && ratio <= 1)) fail("ratio = " + std::to_string(ratio) + " violates 0 < ratio <= 1");
  if (ransac_iterations < 1) fail("ransac_iterations violates ransac_iterations >= 1");
  if (!(inlier_threshold_px > 0)) fail("inlier_threshold_px violates inlier_threshold_px > 0");
  if (min_inliers < 3) fail("min_inliers = " + std::to_string(min_inliers) + " violates min_inliers >= 3");
  if (!(max_residual_rms_px > 0)) fail("max_residual_rms_px violates max_residual_rms_px > 0");
  if (!(min_inlier_fraction >= 0 && min_inlier_fraction <= 1))
    fail("min_inlier_fraction violates 0 <= min_inlier_fraction <= 1");
}

namespace {

int Hamming(const uint8_t* a, const uint8_t* b, int bytes) {
  int d = 0;
  for (int i = 0; i < bytes; i += 8) {
    uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    d += __builtin_popcountll(x ^ y);
  }
  return d;
}

// Sum of absolute differences of a (2r+1)^2 patch at left (ul, v) and right (ul - d, v).
int PatchSad(const cv::Mat& L, const cv::Mat& R, int ul, int v, int d, int r) {
  int s = 0;
  for (int y = v - r; y <= v + r; ++y) {
    const uint8_t* a = L.ptr<uint8_t>(y);
    const uint8_t* b = R.ptr<uint8_t>(y);
    for (int x = ul - r; x <= ul + r; ++x) s += std::abs(int(a[x]) - int(b[x - d]));
  }
  return s;
}

struct Match {
  int left = -1, dist = 1 << 30, second = 1 << 30;
};

}  // namespace

std::vector<DisparitySample> MatchSparseDisparities(const cv::Mat& L, const cv::Mat& R, const RoadFitOptions& o) {
  o.Check();
  if (L.type() != CV_8UC1 || R.type() != CV_8UC1 || L.size() != R.size())
    throw std::invalid_argument("road_model: inputs must be CV_8UC1 images of equal size");
  const double sc = o.detect_scale;
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  // The two views are independent: resize, detect and describe them in parallel.
  auto describe = [&](const cv::Mat& full, std::vector<cv::KeyPoint>* k, cv::Mat* desc) {
    cv::Mat img = full;
    if (sc < 1) cv::resize(full, img, cv::Size(), sc, sc, cv::INTER_AREA);
    auto fast = cv::FastFeatureDetector::create(o.fast_threshold, true);  // one instance per thread
    auto orb = cv::ORB::create(o.max_features, 1.2f, 1);
    fast->detect(img, *k);
    cv::KeyPointsFilter::retainBest(*k, o.max_features);
    orb->compute(img, *k, *desc);
  };
  tbb::parallel_invoke([&] { describe(L, &kl, &dl); }, [&] { describe(R, &kr, &dr); });
  std::vector<DisparitySample> out;
  if (kl.empty() || kr.empty()) return out;

  std::multimap<int, int> right_by_row;
  for (int j = 0; j < static_cast<int>(kr.size()); ++j) right_by_row.emplace(cvRound(kr[j].pt.y), j);
  // The whole common field of view by default: a match at d >= W would lie outside the right image.
  const double max_d = o.max_disparity_px > 0 ? o.max_disparity_px : L.cols - 1.0;
  const double row_diff = o.max_row_diff_px * sc, d_lo = o.min_disparity_px * sc, d_hi = max_d * sc;
  const int row_tol = static_cast<int>(std::ceil(row_diff));
  auto candidates = [&](int i, auto&& fn) {
    const cv::Point2f p = kl[i].pt;
    const int row = cvRound(p.y);
    for (auto it = right_by_row.lower_bound(row - row_tol); it != right_by_row.end() && it->first <= row + row_tol;
         ++it) {
      const cv::Point2f q = kr[it->second].pt;
      const double d = p.x - q.x;
      if (std::abs(p.y - q.y) > row_diff || d <= d_lo || d > d_hi) continue;
      fn(it->second, Hamming(dl.ptr<uint8_t>(i), dr.ptr<uint8_t>(it->second), dl.cols));
    }
  };
  // Best right for each left (with ratio), best left for each right (cross check).
  std::vector<Match> best_left(kl.size()), best_right(kr.size());
  for (int i = 0; i < static_cast<int>(kl.size()); ++i)
    candidates(i, [&](int j, int h) {
      Match& m = best_left[i];
      if (h < m.dist)
        m.second = m.dist, m.dist = h, m.left = j;
      else if (h < m.second)
        m.second = h;
      Match& n = best_right[j];
      if (h < n.dist) n.dist = h, n.left = i;
    });
  const int r = 3;
  for (int i = 0; i < static_cast<int>(kl.size()); ++i) {
    const Match& m = best_left[i];
    if (m.left < 0 || m.dist > o.max_hamming) continue;
    if (m.second < (1 << 30) && m.dist >= o.ratio * m.second) continue;
    if (best_right[m.left].left != i) continue;
    const int ul = cvRound(kl[i].pt.x / sc), v = cvRound(kl[i].pt.y / sc);
    const int d0 = cvRound((kl[i].pt.x - kr[m.left].pt.x) / sc);
    const int search = 1 + static_cast<int>(std::ceil(1.0 / sc));  // a scaled pixel either side, plus one
    // Refine at full size: SAD minimum near d0, then a parabola through its neighbours.
    auto inside = [&](int d) {
      return v - r >= 0 && v + r < L.rows && ul - r >= 0 && ul + r < L.cols && ul - r - d >= 0 && ul + r - d < L.cols;
    };
    if (!inside(d0 - search - 1) || !inside(d0 + search + 1)) continue;
    int bd = d0, bs = 1 << 30;
    for (int d = d0 - search; d <= d0 + search; ++d) {
      const int s = PatchSad(L, R, ul, v, d, r);
      if (s < bs) bs = s, bd = d;
    }
    const int sm = PatchSad(L, R, ul, v, bd - 1, r), sp = PatchSad(L, R, ul, v, bd + 1, r);
    const double den = sm + sp - 2.0 * bs;
    const double sub = den > 0 ? 0.5 * (sm - sp) / den : 0.0;
    const double d = bd + std::clamp(sub, -0.5, 0.5);
    if (d <= o.min_disparity_px || d > max_d) continue;
    if (bd == d0 - search || bd == d0 + search) continue;  // minimum on the search border: unreliable
    out.push_back({double(ul), double(v), d});
  }
  return out;
}

namespace {

// Least-squares plane d = c0 + cu u + cv v over the selected samples.
bool FitPlane(const std::vector<DisparitySample>& s, const std::vector<int>& idx, Eigen::Vector3d* c) {
  if (idx.size() < 3) return false;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int i : idx) {
    const Eigen::Vector3d x(1, s[i].u, s[i].v);
    A += x * x.transpose();
    b += x * s[i].d;
  }
  Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
  if (lu.rank() < 3) return false;
  *c = lu.solve(b);
  return true;
}

}  // namespace

RoadModel FitRoadModel(const std::vector<DisparitySample>& s, int W, int H, const RoadFitOptions& o,
                       const RoadModel* prior) {
  o.Check();
  RoadModel m;
  m.num_matches = static_cast<int>(s.size());
  if (s.size() < 3) {
    if (prior) {
      m = *prior;
      m.num_matches = static_cast<int>(s.size()), m.num_inliers = 0, m.reliable = false, m.from_prior = true;
    }
    return m;
  }
  const double thr = o.inlier_threshold_px;
  auto inliers_of = [&](auto&& model_at, std::vector<int>* idx) {
    idx->clear();
    double sse = 0;
    for (int i = 0; i < static_cast<int>(s.size()); ++i) {
      const double e = s[i].d - model_at(s[i].u, s[i].v);
      if (std::abs(e) <= thr) idx->push_back(i), sse += e * e;
    }
    return sse;
  };
  std::vector<int> best_idx, idx;
  double best_sse = 0;
  bool best_is_prior = false;
  if (prior) {
    best_sse = inliers_of([&](double u, double v) { return prior->At(u, v); }, &best_idx);
    best_is_prior = true;
  }
  std::mt19937 rng(o.seed);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(s.size()) - 1);
  // Adaptive stop: once the best inlier share w makes an all-inlier sample near certain
  // (1 - (1 - w^3)^n >= 99.99 %), more hypotheses cannot be expected to beat it. At least
  // kMinIterations are drawn; the seeded sequence keeps the result deterministic.
  constexpr int kMinIterations = 50;
  auto needed = [&](size_t inliers) {
    const double w = static_cast<double>(inliers) / static_cast<double>(s.size()), p3 = w * w * w;
    if (p3 >= 1.0) return 0.0;
    if (p3 <= 0.0) return static_cast<double>(o.ransac_iterations);
    return std::log(1e-4) / std::log1p(-p3);
  };
  double required = needed(best_idx.size());
  for (int it = 0; it < o.ransac_iterations; ++it) {
    if (it >= kMinIterations && it >= required) break;
    const int i = pick(rng), j = pick(rng), k = pick(rng);
    if (i == j || j == k || i == k) continue;
    Eigen::Matrix3d A;
    A << 1, s[i].u, s[i].v, 1, s[j].u, s[j].v, 1, s[k].u, s[k].v;
    if (std::abs(A.determinant()) < 1e-6) continue;
    const Eigen::Vector3d c = A.partialPivLu().solve(Eigen::Vector3d(s[i].d, s[j].d, s[k].d));
    const double sse = inliers_of([&](double u, double v) { return c[0] + c[1] * u + c[2] * v; }, &idx);
    if (idx.size() > best_idx.size() || (idx.size() == best_idx.size() && sse < best_sse)) {
      best_idx.swap(idx), best_sse = sse, best_is_prior = false;
      required = needed(best_idx.size());
    }
  }
  // Least squares on the inliers, twice (the inlier set settles).
  Eigen::Vector3d c;
  if (!FitPlane(s, best_idx, &c)) {
    if (prior) m = *prior, m.from_prior = true;
    m.num_matches = static_cast<int>(s.size()), m.num_inliers = static_cast<int>(best_idx.size()), m.reliable = false;
    return m;
  }
  for (int pass = 0; pass < 2; ++pass) {
    inliers_of([&](double u, double v) { return c[0] + c[1] * u + c[2] * v; }, &idx);
    if (!FitPlane(s, idx, &c)) break;
    best_idx = idx;
  }
  m.SetPlane(c[0], c[1], c[2]);
  m.from_prior = best_is_prior;
  double sse = inliers_of([&](double u, double v) { return m.At(u, v); }, &best_idx);

  if (o.quadratic && best_idx.size() >= 12) {
    // Normalised coordinates keep the normal equations well conditioned.
    const double su = std::max(1, W), sv = std::max(1, H);
    Eigen::MatrixXd A(best_idx.size(), 6);
    Eigen::VectorXd b(best_idx.size());
    for (size_t r = 0; r < best_idx.size(); ++r) {
      const auto& p = s[best_idx[r]];
      const double x = p.u / su, y = p.v / sv;
      A.row(r) << 1, x, y, x * x, x * y, y * y;
      b[r] = p.d;
    }
    const Eigen::VectorXd q = A.colPivHouseholderQr().solve(b);
    RoadModel mq = m;
    mq.quadratic = true;
    mq.c = {q[0], q[1] / su, q[2] / sv, q[3] / (su * su), q[4] / (su * sv), q[5] / (sv * sv)};
    std::vector<int> qidx;
    const double qsse = inliers_of([&](double u, double v) { return mq.At(u, v); }, &qidx);
    // Keep the quadratic when it explains at least as many matches with a smaller RMS.
    if (qidx.size() >= best_idx.size() &&
        qsse / std::max<size_t>(1, qidx.size()) < sse / std::max<size_t>(1, best_idx.size())) {
      m = mq, best_idx = qidx, sse = qsse;
    }
  }
  m.num_matches = static_cast<int>(s.size());
  m.num_inliers = static_cast<int>(best_idx.size());
  m.residual_rms_px = best_idx.empty() ? 0 : std::sqrt(sse / best_idx.size());
  m.reliable = m.num_inliers >= o.min_inliers && m.residual_rms_px <= o.max_residual_rms_px &&
               m.num_inliers >= o.min_inlier_fraction * m.num_matches;
  return m;
}

DisparityRange DisparityRangeOfMatches(const std::vector<DisparitySample>& s, int width, double margin_px,
                                       int min_matches) {
  DisparityRange r;
  if (s.empty() || static_cast<int>(s.size()) < std::max(1, min_matches) || width < 2) return r;
  std::vector<double> d;
  d.reserve(s.size());
  for (const auto& p : s) d.push_back(p.d);
  std::sort(d.begin(), d.end());
  auto quantile = [&](double q) { return d[static_cast<size_t>(std::lround(q * (d.size() - 1)))]; };
  const double lo = quantile(0.01), hi = quantile(0.99), widen = 0.1 * (hi - lo) + margin_px;
  r.min = std::clamp(static_cast<int>(std::floor(lo - widen)), 0, width - 1);
  const int end = std::clamp(static_cast<int>(std::ceil(hi + widen)) + 1, r.min + 1, width);
  r.num = std::min(end - r.min, 1024);
  return r;
}

double RoadLateralTiltRad(const RoadModel& road, double focal_px, double cx_px, double cy_px) {
  const double cu = -road.a1 * std::sin(road.roll_rad), cv = road.a1 * std::cos(road.roll_rad);
  const double dc = road.a0 + cu * cx_px + cv * cy_px;
  // Signed like phi (= atan2(-c_u, c_v)): a forward view's tilt is its roll.
  const double nx = -focal_px * cu, norm = std::sqrt(nx * nx + focal_px * focal_px * cv * cv + dc * dc);
  return norm > 0 ? std::asin(std::clamp(nx / norm, -1.0, 1.0)) : 0.0;
}

RoadModel FitRoadModelClosedForm(const std::vector<DisparitySample>& s) {
  // For fixed phi, t = v cos(phi) - u sin(phi) and the least-squares residual is
  // Var(d) - Cov(t, d)^2 / Var(t); maximising Cov^2/Var over x = (cos, -sin) is a
  // Rayleigh quotient with maximiser x ~ M^-1 b, M = cov of (v, u), b = cov((v, u), d).
  RoadModel m;
  const double n = static_cast<double>(s.size());
  m.num_matches = static_cast<int>(s.size());
  if (s.size() < 3) return m;
  double mu = 0, mv = 0, md = 0;
  for (const auto& p : s) mu += p.u, mv += p.v, md += p.d;
  mu /= n, mv /= n, md /= n;
  double cuu = 0, cvv = 0, cuv = 0, cud = 0, cvd = 0;
  for (const auto& p : s) {
    const double u = p.u - mu, v = p.v - mv, d = p.d - md;
    cuu += u * u, cvv += v * v, cuv += u * v, cud += u * d, cvd += v * d;
  }
  const double det = cvv * cuu - cuv * cuv;
  if (std::abs(det) < 1e-12) return m;
  const double x = (cuu * cvd - cuv * cud) / det;  // ~ cos(phi)
  const double y = (cvv * cud - cuv * cvd) / det;  // ~ -sin(phi)
  double phi = std::atan2(-y, x);
  if (std::cos(phi) < 0) phi += phi > 0 ? -M_PI : M_PI;
  const double cp = std::cos(phi), sp = std::sin(phi);
  const double var_t = cp * cp * cvv - 2 * cp * sp * cuv + sp * sp * cuu;
  const double cov_td = cp * cvd - sp * cud;
  const double a1 = cov_td / var_t;
  m.SetRoll(md - a1 * (cp * mv - sp * mu), a1, phi);
  double sse = 0;
  for (const auto& p : s) sse += std::pow(p.d - m.At(p.u, p.v), 2);
  m.num_inliers = m.num_matches;
  m.residual_rms_px = std::sqrt(sse / n);
  m.reliable = true;
  return m;
}

}  // namespace rs
