#include "eval/trajectory/trajectory_plot.h"

#include <cmath>

#include <gtest/gtest.h>

namespace rs {
namespace {

// A 20 m circle; the estimate is the same path in another frame (rotated 30 deg, shifted).
PosePairs Circle(double radial_error_m) {
  PosePairs p;
  Eigen::Isometry3d T_other = Eigen::Isometry3d::Identity();
  T_other.linear() = Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_other.translation() = Eigen::Vector3d(5, -3, 1);
  for (int i = 0; i < 200; ++i) {
    const double a = 2 * M_PI * i / 200;
    Eigen::Isometry3d g = Eigen::Isometry3d::Identity();
    g.translation() = Eigen::Vector3d(10 * std::cos(a), 10 * std::sin(a), 0);
    Eigen::Isometry3d e = g;
    e.translation() *= (10 + radial_error_m) / 10;
    p.t_ns.push_back(i * 100'000'000LL);
    p.est_index.push_back(i);
    p.gt_index.push_back(i);
    p.gt.push_back(g);
    p.est.push_back(T_other * e);
  }
  return p;
}

// Pixels of the error curve's blue (BGR 180, 90, 30, blended with white by anti-aliasing) in rows [y0, y1).
int CountBlue(const cv::Mat& img, int y0, int y1) {
  int n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b c = img.at<cv::Vec3b>(y, x);
      n += c[0] > 150 && c[2] < 120 && c[0] > c[1] + 40;
    }
  return n;
}

TEST(TrajectoryPlot, DrawsAlignedPathsAndErrors) {
  const PosePairs pairs = Circle(0.0);
  Sim3Transform S;
  {
    Eigen::Matrix3Xd est(3, pairs.size()), gt(3, pairs.size());
    for (size_t i = 0; i < pairs.size(); ++i) {
      est.col(i) = pairs.est[i].translation();
      gt.col(i) = pairs.gt[i].translation();
    }
    S = UmeyamaAlignment(est, gt, TrajectoryAlignment::kSE3);
  }
  TrajectoryPlotOptions o;
  o.title = "circle";
  const cv::Mat img = PlotTrajectory(pairs, S, o);
  ASSERT_EQ(img.cols, o.width_px);
  ASSERT_EQ(img.rows, o.top_height_px + o.error_height_px);
  // The aligned estimate lies on the truth: the top of the circle (x = 0, y = 10) is drawn in the top
  // panel's upper middle, with the estimate's red over the truth's grey.
  const int margin = 70, pw = o.width_px - 2 * margin, ph = o.top_height_px - 2 * margin;
  const double scale = std::min(pw / 20.0, ph / 20.0);
  const int u = margin + pw / 2, v = static_cast<int>(std::lround(margin + ph / 2.0 - 10 * scale));
  bool red = false, grey = false;
  for (int dy = -3; dy <= 3; ++dy) {
    const cv::Vec3b c = img.at<cv::Vec3b>(v + dy, u);
    red |= c[2] > 150 && c[0] < 120;
    grey |= c[0] > 120 && c[0] < 200 && c[0] == c[1] && c[1] == c[2];
  }
  EXPECT_TRUE(red);
  EXPECT_TRUE(grey);
  // Inside the circle, off the 10 m grid lines, the plot is empty (white).
  const int off = static_cast<int>(std::lround(5 * scale));
  EXPECT_EQ(img.at<cv::Vec3b>(margin + ph / 2 - off, u + off), cv::Vec3b(255, 255, 255));
  // The errors are ~0: the error curve runs along the bottom of the lower panel, over its whole width.
  const int bottom = o.top_height_px + 30 + o.error_height_px - 60;
  EXPECT_GT(CountBlue(img, bottom - 2, bottom + 3), pw * 3 / 4);
  EXPECT_EQ(CountBlue(img, 0, o.top_height_px), 0);
}

TEST(TrajectoryPlot, NeedsTwoPoses) {
  PosePairs p = Circle(0.0);
  p.est.resize(1);
  p.gt.resize(1);
  p.t_ns.resize(1);
  EXPECT_THROW(PlotTrajectory(p, Sim3Transform(), TrajectoryPlotOptions()), std::invalid_argument);
}

}  // namespace
}  // namespace rs
