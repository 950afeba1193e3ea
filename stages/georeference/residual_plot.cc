#include "stages/georeference/residual_plot.h"

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "formats/checked_file.h"

namespace rs {
namespace {

constexpr int kWidth = 1200, kPanelHeight = 260, kHeader = 60, kMarginL = 90, kMarginR = 30;
const cv::Scalar kInk(40, 40, 40), kGrid(215, 215, 215), kPoint(180, 90, 20), kOutlier(30, 30, 220),
    kBand(120, 120, 120);

void DashedHLine(cv::Mat& img, int x0, int x1, int y, const cv::Scalar& c) {
  for (int x = x0; x < x1; x += 12) cv::line(img, {x, y}, {std::min(x + 6, x1), y}, c, 1, cv::LINE_AA);
}

}  // namespace

cv::Mat PlotGnssResiduals(const std::vector<GnssResidual>& res, const Eigen::Vector3d& sigma, const std::string& title) {
  cv::Mat img(kHeader + 3 * kPanelHeight + 40, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(img, title, {kMarginL, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.6, kInk, 1, cv::LINE_AA);
  if (res.empty()) return img;  // the title says why there is nothing to plot
  cv::putText(img, "GNSS fix minus fitted antenna, m; red: outliers; dashed: robust +-3 sigma",
              {kMarginL, 48}, cv::FONT_HERSHEY_SIMPLEX, 0.45, kInk, 1, cv::LINE_AA);
  const double t0 = static_cast<double>(res.front().t_ns), t1 = static_cast<double>(res.back().t_ns);
  const double span_s = std::max((t1 - t0) * 1e-9, 1e-9);
  const char* names[3] = {"east", "north", "up"};
  const int plot_w = kWidth - kMarginL - kMarginR;
  for (int axis = 0; axis < 3; ++axis) {
    const int top = kHeader + axis * kPanelHeight + 10, h = kPanelHeight - 30;
    double lim = 3.5 * sigma[axis];
    for (const auto& r : res) lim = std::max(lim, std::abs(r.r_enu[axis]) * 1.05);
    auto y_of = [&](double v) { return top + static_cast<int>(std::lround((0.5 - 0.5 * v / lim) * h)); };
    auto x_of = [&](int64_t t) { return kMarginL + static_cast<int>(std::lround((t - t0) * 1e-9 / span_s * plot_w)); };
    cv::rectangle(img, {kMarginL, top}, {kMarginL + plot_w, top + h}, kGrid, 1);
    cv::line(img, {kMarginL, y_of(0)}, {kMarginL + plot_w, y_of(0)}, kGrid, 1);
    DashedHLine(img, kMarginL, kMarginL + plot_w, y_of(3 * sigma[axis]), kBand);
    DashedHLine(img, kMarginL, kMarginL + plot_w, y_of(-3 * sigma[axis]), kBand);
    cv::putText(img, names[axis], {8, top + h / 2}, cv::FONT_HERSHEY_SIMPLEX, 0.55, kInk, 1, cv::LINE_AA);
    cv::putText(img, fmt::format("{:+.2f}", lim), {8, top + 12}, cv::FONT_HERSHEY_SIMPLEX, 0.4, kInk, 1, cv::LINE_AA);
    cv::putText(img, fmt::format("{:+.2f}", -lim), {8, top + h}, cv::FONT_HERSHEY_SIMPLEX, 0.4, kInk, 1, cv::LINE_AA);
    for (size_t i = 1; i < res.size(); ++i)
      if (res[i].inlier && res[i - 1].inlier)
        cv::line(img, {x_of(res[i - 1].t_ns), y_of(res[i - 1].r_enu[axis])}, {x_of(res[i].t_ns), y_of(res[i].r_enu[axis])},
                 kGrid, 1, cv::LINE_AA);
    for (const auto& r : res)
      cv::circle(img, {x_of(r.t_ns), y_of(r.r_enu[axis])}, r.inlier ? 3 : 5, r.inlier ? kPoint : kOutlier, cv::FILLED,
                 cv::LINE_AA);
  }
  cv::putText(img, fmt::format("time since the first fitted frame, s (0 .. {:.2f})", span_s),
              {kMarginL, kHeader + 3 * kPanelHeight + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.45, kInk, 1, cv::LINE_AA);
  return img;
}

void WriteGnssResidualPlot(const std::filesystem::path& png, const std::vector<GnssResidual>& residuals,
                           const Eigen::Vector3d& sigma_axis_m, const std::string& title) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", PlotGnssResiduals(residuals, sigma_axis_m, title), bytes))
    throw std::runtime_error("cannot encode " + png.string());
  WriteFileChecked(png, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace rs
