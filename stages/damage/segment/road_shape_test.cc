// The segmentation of a foreign transformed disparity under road shapes it must not report:
// fan2019 dataset3's real frames with a smooth road shape added (a broad sag, a rut along the
// road, a crown across it, a bowl around the pothole). The shapes are smooth, so the pothole's
// label stays the truth; a shape reported as damage costs precision.
#include "stages/damage/damage_pipeline.h"
#include "eval/damage/damage_eval.h"
#include "stages/damage/segment/fan2019_testing.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace rs {
namespace {

struct RoadShape {
  std::string name;
  // Height change (negative = down) at (u, v) for a frame of `size` whose pothole has centroid
  // `c`, extent `r` (px, equivalent radius) and depth `depth` (the image's units).
  std::function<double(double u, double v, cv::Size size, cv::Point2d c, double r, double depth)> offset;
};

const std::vector<RoadShape>& Shapes() {
  static const std::vector<RoadShape> shapes = {
      {"none", [](double, double, cv::Size, cv::Point2d, double, double) { return 0.0; }},
      // A sag four pothole radii wide, half the pothole's depth, away from it.
      {"sag beside",
       [](double u, double v, cv::Size s, cv::Point2d c, double r, double depth) {
         const double cu = c.x < s.width / 2 ? c.x + 6 * r : c.x - 6 * r, cv = s.height * 0.35;
         return -0.5 * depth * std::exp(-0.5 * (std::pow(u - cu, 2) + std::pow(v - cv, 2)) / std::pow(2 * r, 2));
       }},
      // A rut along the road (image columns), two pothole radii wide, a third of its depth.
      {"rut",
       [](double u, double, cv::Size s, cv::Point2d c, double r, double depth) {
         const double cu = c.x < s.width / 2 ? c.x + 5 * r : c.x - 5 * r;
         return -depth / 3.0 * std::exp(-0.5 * std::pow((u - cu) / r, 2));
       }},
      // A crown: the road falls to both edges by the pothole's depth.
      {"crown",
       [](double u, double, cv::Size s, cv::Point2d, double, double depth) {
         const double x = (u - s.width / 2.0) / (s.width / 2.0);
         return -depth * x * x;
       }},
      // The pothole lies in a bowl three radii wide, a third of its depth.
      {"bowl around",
       [](double u, double v, cv::Size, cv::Point2d c, double r, double depth) {
         return -depth / 3.0 * std::exp(-0.5 * (std::pow(u - c.x, 2) + std::pow(v - c.y, 2)) / std::pow(3 * r, 2));
       }},
  };
  return shapes;
}

TEST(SegmentTransformedDisparity, Fan2019Dataset3UnderRoadShapes) {
  const std::vector<test::Fan2019Frame> frames = test::LoadFan2019Dataset3();
  if (frames.empty()) GTEST_SKIP() << "no fan2019 data at " << test::Fan2019Dataset3Dir();
  for (const RoadShape& shape : Shapes()) {
    PixelMetrics overall;
    int instances = 0;
    for (const auto& [name, disp, label] : frames) {
      cv::Mat value;
      disp.convertTo(value, CV_32F);
      const cv::Mat valid = disp > 0, hole = (label > 0) & valid, road = (label == 0) & valid;
      // The pothole's depth: road median less the hole's 10th percentile (robust, the image's units).
      const cv::Moments m = cv::moments(hole, true);
      const cv::Point2d c(m.m10 / m.m00, m.m01 / m.m00);
      const double r = std::sqrt(m.m00 / CV_PI);
      std::vector<float> rv, hv;
      for (int v = 0; v < value.rows; v += 2)
        for (int u = 0; u < value.cols; u += 2) {
          if (road.at<uchar>(v, u)) rv.push_back(value.at<float>(v, u));
          if (hole.at<uchar>(v, u)) hv.push_back(value.at<float>(v, u));
        }
      std::nth_element(rv.begin(), rv.begin() + rv.size() / 2, rv.end());
      std::nth_element(hv.begin(), hv.begin() + hv.size() / 10, hv.end());
      const double depth = rv[rv.size() / 2] - hv[hv.size() / 10];
      for (int v = 0; v < value.rows; ++v)
        for (int u = 0; u < value.cols; ++u)
          if (valid.at<uchar>(v, u))
            value.at<float>(v, u) = std::max(1.0f, value.at<float>(v, u) +
                                                       static_cast<float>(shape.offset(u, v, value.size(), c, r, depth)));
      DamageOptions options;
      options.crack.enabled = false;
      const TransformedSegmentation seg = SegmentTransformedDisparity(value, cv::Mat(), options);
      const PixelMetrics pm = ComparePixels(seg.labels, label);
      std::printf("%-12s %s: depth %.0f radius %.0f px, %zu instances, P %.3f R %.3f F1 %.3f\n", shape.name.c_str(),
                  name.c_str(), depth, r, seg.instances.size(), pm.precision, pm.recall, pm.f1);
      instances += static_cast<int>(seg.instances.size());
      overall.Add(pm);
    }
    std::printf("%-12s overall: %d instances, P %.3f R %.3f F1 %.3f\n", shape.name.c_str(), instances,
                overall.precision, overall.recall, overall.f1);
    EXPECT_GE(overall.f1, 0.90) << shape.name;
  }
}

}  // namespace
}  // namespace rs
