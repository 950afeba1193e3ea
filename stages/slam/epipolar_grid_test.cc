#include "stages/slam/epipolar_grid.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include <gtest/gtest.h>

namespace rs {
namespace {

// Every keypoint within the band of a line is in one of the cells CellsAlongLine returns (the
// triangulation's candidate search must find what a scan of all keypoints finds), each cell once,
// and the cells are far fewer than the grid. Random lines of every direction over a KITTI-size image,
// keypoints at random positions including the image edges.
TEST(EpipolarGrid, CellsCoverTheBand) {
  constexpr int kW = 1226, kH = 370;
  EpipolarGrid grid(kW, kH, 1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> ux(0.f, kW - 1e-3f), uy(0.f, kH - 1e-3f);
  std::vector<cv::KeyPoint> kps;
  for (int i = 0; i < 4000; ++i) kps.emplace_back(ux(rng), uy(rng), 7.f);
  for (float x : {0.f, kW - 1e-3f})
    for (float y : {0.f, kH - 1e-3f}) kps.emplace_back(x, y, 7.f);
  for (size_t i = 0; i < kps.size(); ++i) grid.Add(kps[i], static_cast<int>(i));
  std::uniform_real_distribution<double> angle(0, M_PI), half(0.5, 12);
  std::vector<int> cells;
  size_t total_cells = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const double th = angle(rng), w = half(rng);
    const double a = std::cos(th), b = std::sin(th);  // unit normal
    const double c = -(a * ux(rng) + b * uy(rng));    // through a point of the image
    const double scale = 0.01 + trial;                // lines are not normalised in use
    grid.CellsAlongLine(a * scale, b * scale, c * scale, w, &cells);
    std::set<int> unique(cells.begin(), cells.end());
    ASSERT_EQ(unique.size(), cells.size()) << "a cell listed twice";
    total_cells += cells.size();
    std::set<int> found;
    for (int cell : cells)
      for (const EpipolarGrid::Entry& e : grid.cell(0, cell)) found.insert(e.j);
    for (size_t i = 0; i < kps.size(); ++i)
      if (std::abs(a * kps[i].pt.x + b * kps[i].pt.y + c) < w)
        ASSERT_TRUE(found.count(static_cast<int>(i))) << "trial " << trial << ": keypoint " << i << " missed";
  }
  EXPECT_LT(static_cast<double>(total_cells) / 500, 0.25 * grid.cols() * grid.rows());
}

// A line far outside the image (epipolar lines of distant keyframes can be) crosses no cell.
TEST(EpipolarGrid, LineOffTheImageGivesNoCells) {
  EpipolarGrid grid(1226, 370, 1);
  std::vector<int> cells;
  grid.CellsAlongLine(0.2, 1.0, -1e12, 5, &cells);  // y ~ 1e12
  EXPECT_TRUE(cells.empty());
  grid.CellsAlongLine(1.0, 0.1, 1e12, 5, &cells);  // x ~ -1e12
  EXPECT_TRUE(cells.empty());
}

TEST(EpipolarGrid, DegenerateLineGivesNoCells) {
  EpipolarGrid grid(100, 100, 2);
  std::vector<int> cells = {1, 2};
  grid.CellsAlongLine(0, 0, 1, 3, &cells);
  EXPECT_TRUE(cells.empty());
}

}  // namespace
}  // namespace rs
