#include "eval/trajectory/trajectory_plot.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace rs {
namespace {

const cv::Scalar kTruth(150, 150, 150), kEstimate(40, 70, 220), kError(180, 90, 30), kAxis(0, 0, 0),
    kGrid(225, 225, 225);

// A "nice" tick step (1, 2 or 5 x 10^k) giving about `ticks` intervals over `range`.
double TickStep(double range, int ticks) {
  const double raw = std::max(range, 1e-9) / ticks;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (raw <= m * p) return m * p;
  return 10 * p;
}

void Text(cv::Mat* img, const std::string& s, cv::Point at, double scale = 0.5, const cv::Scalar& colour = kAxis) {
  cv::putText(*img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

}  // namespace

cv::Mat PlotTrajectory(const PosePairs& pairs, const Sim3Transform& alignment, const TrajectoryPlotOptions& o) {
  if (pairs.size() < 2) throw std::invalid_argument("PlotTrajectory needs at least 2 associated poses");
  const size_t n = pairs.size();
  std::vector<Eigen::Vector3d> gt(n), est(n);
  std::vector<double> err(n);
  for (size_t i = 0; i < n; ++i) {
    gt[i] = pairs.gt[i].translation();
    est[i] = alignment.Apply(pairs.est[i].translation());
    err[i] = (gt[i] - est[i]).norm();
  }
  cv::Mat img(o.top_height_px + o.error_height_px, o.width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  const int margin = 70;

  // --- top view, equal scales on x (east) and y (north)
  double x0 = gt[0].x(), x1 = x0, y0 = gt[0].y(), y1 = y0;
  for (size_t i = 0; i < n; ++i)
    for (const Eigen::Vector3d* p : {&gt[i], &est[i]}) {
      x0 = std::min(x0, p->x());
      x1 = std::max(x1, p->x());
      y0 = std::min(y0, p->y());
      y1 = std::max(y1, p->y());
    }
  const int pw = o.width_px - 2 * margin, ph = o.top_height_px - 2 * margin;
  const double scale = std::min(pw / std::max(x1 - x0, 1e-6), ph / std::max(y1 - y0, 1e-6));
  const double cxm = 0.5 * (x0 + x1), cym = 0.5 * (y0 + y1);
  auto to_px = [&](const Eigen::Vector3d& p) {
    return cv::Point2d(margin + pw / 2.0 + (p.x() - cxm) * scale, margin + ph / 2.0 - (p.y() - cym) * scale);
  };
  const double half_w = pw / 2.0 / scale, half_h = ph / 2.0 / scale;
  const double step = TickStep(2 * std::max(half_w, half_h), 8);
  for (double gx = std::ceil((cxm - half_w) / step) * step; gx <= cxm + half_w; gx += step) {
    const int u = static_cast<int>(std::lround(to_px({gx, cym, 0}).x));
    cv::line(img, {u, margin}, {u, margin + ph}, kGrid);
    Text(&img, fmt::format("{:g}", gx), {u - 15, margin + ph + 18}, 0.4);
  }
  for (double gy = std::ceil((cym - half_h) / step) * step; gy <= cym + half_h; gy += step) {
    const int v = static_cast<int>(std::lround(to_px({cxm, gy, 0}).y));
    cv::line(img, {margin, v}, {margin + pw, v}, kGrid);
    Text(&img, fmt::format("{:g}", gy), {5, v + 4}, 0.4);
  }
  cv::rectangle(img, {margin, margin}, {margin + pw, margin + ph}, kAxis);
  auto polyline = [&](const std::vector<Eigen::Vector3d>& p, const cv::Scalar& colour, int thickness) {
    std::vector<cv::Point> pts;
    for (const auto& x : p) {
      const cv::Point2d q = to_px(x);
      pts.emplace_back(static_cast<int>(std::lround(q.x * 4)), static_cast<int>(std::lround(q.y * 4)));
    }
    cv::polylines(img, pts, false, colour, thickness, cv::LINE_AA, 2);  // 2 fractional bits
  };
  polyline(gt, kTruth, 5);
  polyline(est, kEstimate, 1);
  cv::circle(img, to_px(gt.front()), 6, kAxis, 2, cv::LINE_AA);
  Text(&img, o.title, {margin, 25}, 0.6);
  Text(&img, "top view, x east / y north [m]: truth (grey, wide), estimate after alignment (red); circle = start",
       {margin, 50}, 0.5);

  // --- ATE error over time
  const int top = o.top_height_px + 30, eh = o.error_height_px - 60;
  const double t0 = static_cast<double>(pairs.t_ns.front()), t1 = static_cast<double>(pairs.t_ns.back());
  const double tspan = std::max((t1 - t0) * 1e-9, 1e-9);
  const double emax = std::max(*std::max_element(err.begin(), err.end()), 1e-6) * 1.1;
  const double estep = TickStep(emax, 4), tstep = TickStep(tspan, 10);
  auto err_px = [&](size_t i) {
    return cv::Point(static_cast<int>(std::lround(margin + (pairs.t_ns[i] - t0) * 1e-9 / tspan * pw)),
                     static_cast<int>(std::lround(top + eh - err[i] / emax * eh)));
  };
  for (double e = 0; e <= emax; e += estep) {
    const int v = static_cast<int>(std::lround(top + eh - e / emax * eh));
    cv::line(img, {margin, v}, {margin + pw, v}, kGrid);
    Text(&img, fmt::format("{:g}", e), {5, v + 4}, 0.4);
  }
  for (double t = 0; t <= tspan; t += tstep) {
    const int u = static_cast<int>(std::lround(margin + t / tspan * pw));
    Text(&img, fmt::format("{:g}", t), {u - 10, top + eh + 18}, 0.4);
  }
  cv::rectangle(img, {margin, top}, {margin + pw, top + eh}, kAxis);
  std::vector<cv::Point> ep;
  for (size_t i = 0; i < n; ++i) ep.push_back(err_px(i));
  cv::polylines(img, ep, false, kError, 1, cv::LINE_AA);
  double sq = 0;
  for (double e : err) sq += e * e;
  Text(&img,
       fmt::format("ATE per pose [m] over time [s]  (RMSE {:.3f} m, max {:.3f} m, {} poses)", std::sqrt(sq / n),
                   *std::max_element(err.begin(), err.end()), n),
       {margin, top - 10}, 0.5);
  return img;
}

void WriteTrajectoryPlot(const std::filesystem::path& png, const PosePairs& pairs, const Sim3Transform& alignment,
                         const TrajectoryPlotOptions& options) {
  const cv::Mat img = PlotTrajectory(pairs, alignment, options);
  if (!cv::imwrite(png.string(), img)) throw std::runtime_error("cannot write trajectory plot " + png.string());
}

}  // namespace rs
