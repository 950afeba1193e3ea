// The height grid's fusion: robust per-cell fusion, the best views kept, tiles spilled and brought
// back without loss, a frame's pixels placed in the CRS, and the CRS linearised per frame.
#include <gtest/gtest.h>

#include <GeographicLib/LocalCartesian.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <random>

#include "stages/surface/frame_cells.h"
#include "stages/surface/hole_fill.h"
#include "stages/surface/surface_frames.h"
#include "stages/surface/tile_accumulator.h"
#include "stages/surface/tile_store.h"

namespace rs {
namespace {
namespace fs = std::filesystem;

CellObservation Obs(float h, float s) {
  CellObservation o;
  o.height_m = h;
  o.sigma_m = s;
  return o;
}

TEST(FuseCell, OutlierViewDoesNotMoveTheHeight) {
  // Five views agree within their 2 mm σ; one mismatched view is 20 cm off.
  const CellObservation obs[] = {Obs(1.000f, 0.002f), Obs(1.001f, 0.002f), Obs(0.999f, 0.002f),
                                 Obs(1.002f, 0.002f), Obs(0.998f, 0.002f), Obs(1.200f, 0.002f)};
  float h = 0, s = 0;
  ASSERT_TRUE(FuseCell(obs, 6, &h, &s));
  EXPECT_NEAR(h, 1.000, 0.0015);  // a plain mean would be 1.033
  EXPECT_GT(s, 0.0008);           // the disagreement inflates σ above 2 mm / sqrt(6)
  EXPECT_LT(s, 0.01);
  EXPECT_FALSE(FuseCell(obs, 0, &h, &s));
}

TEST(FuseCell, WeightsByUncertainty) {
  const CellObservation obs[] = {Obs(1.000f, 0.001f), Obs(1.010f, 0.010f)};
  float h = 0, s = 0;
  ASSERT_TRUE(FuseCell(obs, 2, &h, &s));
  EXPECT_NEAR(h, 1.0001, 0.0002);  // inverse-variance weights 100 : 1
  EXPECT_NEAR(s, 0.001 / std::sqrt(1.01), 1e-4);
}

TEST(TileAccumulator, KeepsTheMostCertainViews) {
  TileAccumulator t(4, 3);
  // Far, uncertain views see the cell 5 cm too high; three near views see it right.
  for (int i = 0; i < 5; ++i) t.Add(2, Obs(1.05f, 0.02f + 0.001f * i));
  for (int i = 0; i < 3; ++i) t.Add(2, Obs(1.0f, 0.002f));
  const FusedTile f = t.Fuse(2);
  EXPECT_NEAR(f.height_m.at<float>(1, 0), 1.0f, 1e-4);
  EXPECT_EQ(f.count.at<uint16_t>(1, 0), 8);
  EXPECT_TRUE(std::isnan(f.height_m.at<float>(0, 0)));
  EXPECT_EQ(f.count.at<uint16_t>(0, 0), 0);
}

TEST(TileStore, FinishesSpillsAndReloadsWithoutLoss) {
  const fs::path spill = fs::temp_directory_path() / ("rs_tile_store_" + std::to_string(::getpid()));
  std::map<int, FusedTile> emitted;
  const auto emit = [&](int tile, const TileAccumulator& a) { emitted[tile] = a.Fuse(2); };
  {
    // Tile 0 is seen by frames 0 and 5 (a return pass), tile 1 by frame 0 only, tile 2 never.
    TileStore store(4, 2, {5, 0, -1}, spill);
    store.Touch(0, 0).Add(0, Obs(2.0f, 0.01f));
    store.Touch(1, 0).Add(3, Obs(3.0f, 0.01f));
    store.Release(0, 2, emit);
    EXPECT_EQ(emitted.count(1), 1u) << "tile 1 is finished after frame 0";
    EXPECT_EQ(emitted.count(0), 0u);
    store.Release(2, 2, emit);  // frames 1 and 2 did not touch tile 0: spilled
    EXPECT_EQ(store.spills(), 1);
    EXPECT_TRUE(fs::exists(spill));
    store.Touch(0, 5).Add(0, Obs(2.002f, 0.01f));
    EXPECT_EQ(store.reloads(), 1);
    store.Release(5, 2, emit);
    ASSERT_EQ(emitted.count(0), 1u);
    EXPECT_NEAR(emitted[0].height_m.at<float>(0, 0), 2.001f, 1e-4) << "both passes fused";
    EXPECT_EQ(emitted[0].count.at<uint16_t>(0, 0), 2);
    EXPECT_NEAR(emitted[1].height_m.at<float>(1, 1), 3.0f, 1e-6);
    store.Finish(emit);
    EXPECT_EQ(emitted.size(), 2u);
  }
  EXPECT_FALSE(fs::exists(spill)) << "spill folder removed";
}

// A tilted plane with three holes: a small one inside (filled from its rim, close to the plane, count
// still 0), a wide one inside and one at the tile's edge (both left: the edge may continue next door).
TEST(FillSmallHoles, FillsOnlySmallInteriorHoles) {
  const int n = 40;
  FusedTile t;
  t.height_m.create(n, n, CV_32F);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) t.height_m.at<float>(r, c) = 100.0f + 0.001f * c + 0.0005f * r;
  t.sigma_m = cv::Mat(n, n, CV_32F, cv::Scalar(0.002));
  t.count = cv::Mat(n, n, CV_16U, cv::Scalar(5));
  t.colour = cv::Mat(n, n, CV_8UC3, cv::Scalar(90, 90, 90));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto punch = [&](cv::Rect r) {
    t.height_m(r).setTo(nan), t.sigma_m(r).setTo(nan), t.count(r).setTo(0), t.colour(r).setTo(cv::Scalar::all(0));
  };
  punch({10, 10, 3, 3});   // 3 cells wide
  punch({20, 20, 12, 12});  // 12 cells wide
  punch({0, 30, 3, 3});     // at the edge
  EXPECT_EQ(FillSmallHoles(&t, 5.0), 9);
  EXPECT_NEAR(t.height_m.at<float>(11, 11), 100.0f + 0.011f + 0.0055f, 0.0015);
  EXPECT_EQ(t.count.at<uint16_t>(11, 11), 0) << "filled cells say no view saw them";
  EXPECT_GT(t.sigma_m.at<float>(11, 11), 0.002f);
  EXPECT_NEAR(t.colour.at<cv::Vec3b>(11, 11)[0], 90, 2);
  EXPECT_TRUE(std::isnan(t.height_m.at<float>(25, 25)));
  EXPECT_TRUE(std::isnan(t.height_m.at<float>(31, 1)));
}

// A nadir camera 5 m above flat ground at height 100 m: every pixel lands at 100 m, and its σ is
// the stereo depth error Z² σ_d / (f B).
TEST(FrameCells, NadirViewOfFlatGround) {
  FrameView v;
  v.camera = {500, 99.5, 49.5, 0.2, 200, 100};
  const double Z = 5.0;
  v.disparity_px = cv::Mat(100, 200, CV_32F, cv::Scalar(v.camera.bf() / Z));
  v.colour = cv::Mat(100, 200, CV_8UC3, cv::Scalar(10, 20, 30));
  v.sigma_disparity_px = 0.2;
  // camera x right = east, y down = south, z forward = down; camera at (1000, 2000, 105).
  v.crs_from_camera << 1, 0, 0, 1000, 0, -1, 0, 2000, 0, 0, -1, 105;
  SurfaceGrid g;
  g.x_min = 998, g.y_max = 2002, g.cell = 0.02, g.cols = 200, g.rows = 200, g.tile = 64;
  const auto cells = FrameCellObservations(v, g);
  ASSERT_GT(cells.size(), 3000u);
  for (const CellSample& c : cells) {
    EXPECT_NEAR(c.obs.height_m, 100.0, 1e-4);
    EXPECT_NEAR(c.obs.sigma_m, Z * Z * 0.2 / v.camera.bf(), 1e-3);
    EXPECT_EQ(c.obs.bgr[2], 30);
  }
  // The footprint is 2 m × 1 m around (1000, 2000) (pixel size 1 cm at 5 m).
  double x0 = 1e9, x1 = -1e9;
  for (const auto& p : FrameFootprint(v, 4)) x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x());
  EXPECT_NEAR(x0, 999.0, 0.02);
  EXPECT_NEAR(x1, 1000.96, 0.05);
  EXPECT_NEAR(MedianPixelFootprintM(v, 4), 0.01, 1e-6);
  // Obstacle pixels (use = 0) are not fused.
  v.use = cv::Mat(100, 200, CV_8U, cv::Scalar(0));
  EXPECT_TRUE(FrameCellObservations(v, g).empty());
}

// The per-frame linearisation of UTM against PROJ point by point, 15 m from the camera.
TEST(CrsFromCamera, LinearisedUtmWithinATenthOfAMillimetre) {
  GeoreferenceFile geo;
  geo.georeferenced = true;
  geo.origin = {46.0569, 14.5058, 300.0};
  geo.crs_spec = "utm";
  geo.scale = 1.0001;
  geo.R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  geo.t = {12, -7, 3};
  const auto crs = geo.MakeCrs();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();  // looking down
  T.translation() = Eigen::Vector3d(40, 25, 8);
  const Eigen::Matrix<double, 3, 4> M = CrsFromCamera(T, geo, *crs);
  const GeographicLib::LocalCartesian enu(geo.origin.lat_deg, geo.origin.lon_deg, geo.origin.h_ellipsoid_m);
  for (const Eigen::Vector3d& x_cam : {Eigen::Vector3d(0, 0, 6), Eigen::Vector3d(12, -9, 6), Eigen::Vector3d(-10, 8, 3)}) {
    const Eigen::Vector3d p = geo.ToEnu(T * x_cam);
    Geodetic gd;
    enu.Reverse(p.x(), p.y(), p.z(), gd.lat_deg, gd.lon_deg, gd.h_ellipsoid_m);
    const Eigen::Vector3d exact = crs->Forward(gd);
    const Eigen::Vector3d lin = M.leftCols<3>() * x_cam + M.col(3);
    EXPECT_LT((exact - lin).norm(), 1e-4) << x_cam.transpose();
  }
}

}  // namespace
}  // namespace rs
