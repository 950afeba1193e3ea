#include <gtest/gtest.h>

#include <cmath>

#include "stages/damage_map/chainage.h"
#include "stages/damage_map/footprint_overlap.h"
#include "stages/damage_map/fuse_crack.h"
#include "stages/damage_map/fuse_depression.h"
#include "stages/damage_map/link_cracks.h"
#include "stages/damage_map/view_coverage.h"

namespace rs {
namespace {

// A rectangle [x0, x1] × [y0, y1] at height z as a ring.
std::vector<Eigen::Vector3d> Rect(double x0, double y0, double x1, double y1, double z = 0) {
  return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
}

// A circle of radius r around (cx, cy).
std::vector<Eigen::Vector3d> Disk(double cx, double cy, double r) {
  std::vector<Eigen::Vector3d> ring;
  for (int i = 0; i < 48; ++i) ring.emplace_back(cx + r * std::cos(i * M_PI / 24), cy + r * std::sin(i * M_PI / 24), 0);
  return ring;
}

MapObservation View(int64_t frame, std::vector<Eigen::Vector3d> ring, double depth, double sigma, bool complete = true,
                    bool floor = true, const std::string& type = "pothole") {
  MapObservation o;
  o.frame = frame;
  o.outline_enu = std::move(ring);
  o.complete = complete;
  o.detection.type = type;
  o.detection.max_depth_m = depth;
  o.detection.sigma_depth_m = sigma;
  o.detection.mean_depth_m = depth / 2;
  o.detection.area_m2 = 0.2;
  o.detection.sigma_area_m2 = 0.01;
  o.detection.volume_m3 = 0.004;
  o.detection.sigma_volume_m3 = 0.0004;
  o.detection.max_diameter_m = 0.5;
  o.detection.floor_visible = floor;
  o.detection.max_depth_seen_m = depth;
  o.detection.max_depth_bound_m = floor ? NAN : depth + 0.02;
  return o;
}

TEST(FootprintOverlap, ToleratesPoseErrorAndPartialViews) {
  const Footprint whole = FootprintOf(Disk(0, 0, 0.25));
  EXPECT_GT(OverlapOfSmaller(whole, FootprintOf(Disk(0.03, -0.02, 0.25)), 0.05, 0.01), 0.99);
  // A view cut by the image border: half the pothole, still the same damage (the half-disk itself,
  // and its bounding box, whose corners reach 0.35 m out: 5 % beyond the 0.30 m buffer).
  std::vector<Eigen::Vector3d> half;
  for (int i = 12; i <= 36; ++i) half.emplace_back(0.25 * std::cos(i * M_PI / 24), 0.25 * std::sin(i * M_PI / 24), 0);
  EXPECT_GT(OverlapOfSmaller(whole, FootprintOf(half), 0.05, 0.01), 0.99);
  EXPECT_NEAR(OverlapOfSmaller(whole, FootprintOf(Rect(-0.25, -0.25, 0.0, 0.25)), 0.05, 0.01), 0.947, 0.02);
  // A neighbouring pothole 10 cm beyond the rim is another damage.
  EXPECT_EQ(OverlapOfSmaller(whole, FootprintOf(Disk(0.7, 0, 0.2)), 0.05, 0.01), 0.0);
}

TEST(FootprintOverlap, GroupsViewsOfEachDamageOnce) {
  std::vector<Footprint> f;
  for (int k = 0; k < 4; ++k) f.push_back(FootprintOf(Disk(0.01 * k, 0.005 * k, 0.2)));   // pothole A, 4 views
  for (int k = 0; k < 3; ++k) f.push_back(FootprintOf(Disk(1.5 - 0.01 * k, 0.3, 0.15)));  // pothole B, 3 views
  const auto groups = GroupByOverlap(f, 0.05, 0.01, 0.3);
  ASSERT_EQ(groups.size(), 2u);
  EXPECT_EQ(groups[0], (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(groups[1], (std::vector<int>{4, 5, 6}));
}

TEST(FuseDepression, TheBestViewsDecideNotTheAverage) {
  std::vector<MapObservation> obs = {
      View(1, Disk(0, 0, 0.25), 0.060, 0.004, /*complete=*/false),     // cut by the border: wrong area
      View(2, Disk(0, 0, 0.25), 0.031, 0.002),                         // near, floor seen
      View(3, Disk(0, 0, 0.25), 0.029, 0.002),                         // near, floor seen
      View(4, Disk(0, 0, 0.25), 0.020, 0.008, true, /*floor=*/false),  // far, rim hides the floor
  };
  const MappedDamage m = FuseDepression(obs, {0, 1, 2, 3}, FusionOptions{3});
  EXPECT_EQ(m.used, (std::vector<int>{1, 2}));
  EXPECT_NEAR(m.max_depth_m.value, 0.030, 1e-9);
  EXPECT_GE(m.max_depth_m.sigma, 0.002 - 1e-12);  // views of one surface: σ does not shrink as 1/√n
  EXPECT_TRUE(m.floor_visible);
  EXPECT_TRUE(m.outline_complete);
  EXPECT_EQ(m.type, "pothole");
  EXPECT_NE(m.basis.find("frames 2, 3"), std::string::npos) << m.basis;
}

TEST(FuseDepression, HiddenFloorGivesTheIntersectionOfTheViewsIntervals) {
  std::vector<MapObservation> obs = {View(1, Disk(0, 0, 0.2), 0.030, 0.002, true, false),
                                     View(2, Disk(0, 0, 0.2), 0.036, 0.002, true, false)};
  obs[0].detection.max_depth_bound_m = 0.070;
  obs[1].detection.max_depth_bound_m = 0.055;
  const MappedDamage m = FuseDepression(obs, {0, 1}, FusionOptions{3});
  EXPECT_FALSE(m.floor_visible);
  EXPECT_NEAR(m.max_depth_seen_m, 0.036 - 0.004, 1e-12);  // the deepest seen, less 2σ
  EXPECT_NEAR(m.max_depth_bound_m, 0.055, 1e-12);         // the tightest bound
  EXPECT_GE(m.max_depth_m.value, m.max_depth_seen_m);
  EXPECT_LE(m.max_depth_m.value, m.max_depth_bound_m);
}

TEST(FuseCrack, PiecesOfOneCrackBecomeOneCentreline) {
  // A 2 m crack, 8 mm wide, along x; three frames each see a piece, overlapping.
  std::vector<MapObservation> obs;
  const double w = 0.004;
  obs.push_back(View(1, Rect(0.0, -w, 0.9, w), NAN, NAN, true, true, "crack"));
  obs.push_back(View(2, Rect(0.6, -w, 1.5, w), NAN, NAN, true, true, "crack"));
  obs.push_back(View(3, Rect(1.2, -w, 2.0, w), NAN, NAN, true, true, "crack"));
  for (auto& o : obs) {
    o.detection.mean_width_m = 0.008;
    o.detection.max_width_m = 0.010;
    o.detection.range_m = 3.0;
  }
  std::vector<Footprint> f;
  for (const auto& o : obs) f.push_back(FootprintOf(o.outline_enu));
  ASSERT_EQ(GroupByOverlap(f, 0.05, 0.005, 0.1).size(), 1u);
  const MappedDamage m = FuseCrack(obs, {0, 1, 2}, CrackFusionOptions{});
  EXPECT_NEAR(m.length_m.value, 2.0, 0.03);  // the thinned skeleton loses at most a cell or two per end
  EXPECT_NEAR(m.width_m.value, 0.008, 1e-12);
  EXPECT_EQ(m.type, "crack");
  ASSERT_GE(m.geometry_enu.size(), 2u);
  EXPECT_NEAR(std::abs(m.geometry_enu.front().x() - m.geometry_enu.back().x()), 2.0, 0.03);
}

TEST(FuseCrack, AGapWiderThanTheToleranceKeepsTwoCracks) {
  std::vector<Footprint> f = {FootprintOf(Rect(0.0, -0.004, 0.9, 0.004)), FootprintOf(Rect(1.1, -0.004, 2.0, 0.004))};
  EXPECT_EQ(GroupByOverlap(f, 0.05, 0.005, 0.1).size(), 2u);
}

// Straight polyline from (x0, y0) to (x1, y1) in 1 cm steps.
std::vector<Eigen::Vector3d> Line(double x0, double y0, double x1, double y1) {
  const int n = static_cast<int>(std::ceil(std::hypot(x1 - x0, y1 - y0) / 0.01));
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i <= n; ++i) line.emplace_back(x0 + (x1 - x0) * i / n, y0 + (y1 - y0) * i / n, 0);
  return line;
}

TEST(LinkCracks, EndsAndTheirOutwardDirections) {
  const auto ends = CrackEnds(Line(0, 0, 1, 0), 0.1);
  ASSERT_EQ(ends.size(), 2u);
  EXPECT_NEAR(ends[0].point.x(), 0, 1e-12);
  EXPECT_NEAR(ends[0].outward.x(), -1, 1e-9);
  EXPECT_NEAR(ends[1].point.x(), 1, 1e-12);
  EXPECT_NEAR(ends[1].outward.x(), 1, 1e-9);
  EXPECT_TRUE(CrackEnds({{0, 0, 0}}, 0.1).empty());
}

TEST(LinkCracks, PiecesAlongOneLineAcrossShortGapsAreOneCrack) {
  // Three pieces of one crack along x, gaps of 0.2 m and 0.15 m (slightly bent); a parallel crack
  // 0.3 m beside it; a piece across the line's end (a T, 0.1 m off, perpendicular); a piece 0.4 m
  // beyond the last gap.
  const std::vector<std::vector<Eigen::Vector3d>> lines = {Line(0, 0, 1, 0),           Line(1.2, 0.02, 2.0, 0.05),
                                                           Line(2.15, 0.05, 3.0, 0.0), Line(0, 0.3, 3, 0.3),
                                                           Line(3.1, -0.5, 3.1, 0.5),  Line(3.4, 0, 4, 0)};
  std::vector<CrackBridge> bridges;
  const auto groups = LinkCrackPieces(lines, CrackLinkOptions{}, 0.05, &bridges);
  ASSERT_EQ(groups.size(), 4u);
  EXPECT_EQ(groups[0], (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(groups[1], (std::vector<int>{3}));
  EXPECT_EQ(groups[2], (std::vector<int>{4}));
  EXPECT_EQ(groups[3], (std::vector<int>{5}));
  ASSERT_EQ(bridges.size(), 2u);
  EXPECT_NEAR((bridges[0].segment[1] - bridges[0].segment[0]).norm(), std::hypot(0.2, 0.02), 1e-9);
  // No linking at all, and a gap beyond the limit.
  EXPECT_EQ(LinkCrackPieces(lines, CrackLinkOptions{0.0}, 0.05, nullptr).size(), lines.size());
  EXPECT_EQ(LinkCrackPieces(lines, CrackLinkOptions{0.1}, 0.05, nullptr).size(), lines.size());
}

TEST(LinkCracks, ALinkedCrackIsOneCentrelineThroughTheGap) {
  // Two views each see the same two pieces of a 2 m crack with a 0.2 m gap at [0.9, 1.1].
  std::vector<MapObservation> obs;
  const double w = 0.004;
  for (int f = 1; f <= 2; ++f) {
    obs.push_back(View(f, Rect(0.0, -w, 0.9, w), NAN, NAN, true, true, "crack"));
    obs.push_back(View(f, Rect(1.1, -w, 2.0, w), NAN, NAN, true, true, "crack"));
  }
  const MappedDamage a = FuseCrack(obs, {0, 2}, CrackFusionOptions{});
  const MappedDamage b = FuseCrack(obs, {1, 3}, CrackFusionOptions{});
  std::vector<CrackBridge> bridges;
  const auto groups = LinkCrackPieces({a.geometry_enu, b.geometry_enu}, CrackLinkOptions{}, 0.05, &bridges);
  ASSERT_EQ(groups.size(), 1u);
  ASSERT_EQ(bridges.size(), 1u);
  const MappedDamage m = FuseCrack(obs, {0, 1, 2, 3}, CrackFusionOptions{}, {bridges[0].segment});
  EXPECT_NEAR(m.length_m.value, 2.0, 0.03);
  EXPECT_NE(m.basis.find("1 gap(s) between pieces bridged"), std::string::npos) << m.basis;
}

TEST(Centreline, ChainageAlongAndOffsetRightOfTravel) {
  // Driving east along y = 0, then turning north at x = 10.
  std::vector<Eigen::Vector3d> track;
  for (int i = 0; i <= 100; ++i) track.emplace_back(0.1 * i, 0, 0);
  for (int i = 1; i <= 50; ++i) track.emplace_back(10, 0.1 * i, 0);
  const Centreline line(track);
  EXPECT_NEAR(line.length_m(), 15.0, 1e-9);
  auto s = line.StationOf({4.0, -1.5, 0});  // south of an eastward line: right
  EXPECT_NEAR(s.chainage_m, 4.0, 1e-9);
  EXPECT_NEAR(s.offset_m, 1.5, 1e-9);
  s = line.StationOf({9.0, 3.0, 0});  // west of the northward leg: left
  EXPECT_NEAR(s.chainage_m, 13.0, 1e-9);
  EXPECT_NEAR(s.offset_m, -1.0, 1e-9);
  s = line.StationOf({-2.0, 0.5, 0});  // before the start: negative chainage
  EXPECT_NEAR(s.chainage_m, -2.0, 1e-9);
}

TEST(Centreline, OutAndBackIsReferencedOnTheFirstPass) {
  // East along y = 0 to x = 10, then back west along y = 0.5.
  std::vector<Eigen::Vector3d> track;
  for (int i = 0; i <= 100; ++i) track.emplace_back(0.1 * i, 0, 0);
  for (int i = 100; i >= 0; --i) track.emplace_back(0.1 * i, 0.5, 0);
  const Centreline line(track);
  const auto s = line.StationOf({3.0, 0.45, 0});  // nearer the return pass
  EXPECT_NEAR(s.chainage_m, 3.0, 1e-9);
  EXPECT_NEAR(s.offset_m, -0.45, 1e-9);  // left of the first pass's travel
}

TEST(GradeMappedDamage, GradesTheFusedFigures) {
  MappedDamage m;
  m.type = "pothole";
  m.max_depth_m.value = 0.045;
  m.area_m2.value = 0.1;
  m.equivalent_diameter_m = std::sqrt(4 * 0.1 / M_PI);  // 357 mm
  m.max_diameter_m = 0.40;
  GradeMappedDamage(m, SeverityOptions{});
  EXPECT_EQ(m.astm.level, SeverityLevel::kMedium);  // (25, 50] mm × (200, 450] mm
  EXPECT_EQ(m.severity, "medium");
  EXPECT_TRUE(m.intervention.needed);  // ≥ 40 mm deep and ≥ 300 mm wide
  EXPECT_NE(m.astm.rule.find("45 mm"), std::string::npos) << m.astm.rule;
}

// A nadir camera 4 m above the ENU origin (x east, y south in the image): what it has in view.
TEST(ViewCoverage, InViewNeedsFrontImageAndAnalysedRange) {
  RectifiedStereo cam;
  cam.f_px = 100;
  cam.cx_px = 50;
  cam.cy_px = 50;
  cam.baseline_m = 0.1;
  cam.width = cam.height = 101;
  ExaminedView v;
  v.frame = 3;
  v.camera_from_enu.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // camera from ENU: looking down
  v.camera_from_enu.translation() = Eigen::Vector3d(0, 0, 4);
  EXPECT_TRUE(InView(v, cam, {0, 0, 0}, 2));
  EXPECT_TRUE(InView(v, cam, {1.9, 1.9, 0}, 2));  // u = v = 97.5 px
  EXPECT_FALSE(InView(v, cam, {1.98, 0, 0}, 2));  // u = 99.5 px: within the border
  EXPECT_FALSE(InView(v, cam, {0, 0, 5}, 2));     // behind the camera
  v.analysed_range_m = 3.5;
  EXPECT_FALSE(InView(v, cam, {0, 0, 0}, 2));  // 4 m away: beyond the analysed range
  EXPECT_EQ(FramesInView({v}, cam, {0, 0, 1}, 2), (std::vector<int64_t>{3}));
}

TEST(ViewCoverage, PolylineMidpointIsHalfwayAlong) {
  const Eigen::Vector3d m = PolylineMidpoint({{0, 0, 0}, {1, 0, 0}, {1, 3, 0}});
  EXPECT_NEAR(m.x(), 1, 1e-12);
  EXPECT_NEAR(m.y(), 1, 1e-12);
}

}  // namespace
}  // namespace rs
