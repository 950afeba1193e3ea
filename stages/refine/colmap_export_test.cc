#include "stages/refine/colmap_export.h"
#include "stages/refine/refine_steps.h"

#include <gtest/gtest.h>

#include <random>

namespace rs {
namespace {

// A stereo map with exact observations, then one gross outlier and one coarse-level observation.
SlamMapFile SyntheticMap() {
  SlamMapFile m;
  m.camera = {640, 480, 500, 500, 320, 240, 0.5};
  for (int k = 0; k < 4; ++k) {
    SlamMapKeyframe kf;
    kf.id = 10 + k;
    kf.t_ns = 1000 + k;
    kf.T_cam_world.translation() = Eigen::Vector3d(-0.3 * k, 0, 0);  // moving along +x
    m.keyframes.push_back(kf);
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(-1, 1), z(5, 10);  // inside both images
  for (int p = 0; p < 30; ++p) {
    SlamMapPoint pt;
    pt.id = p;
    pt.p_world = Eigen::Vector3d(x(rng), x(rng), z(rng));
    for (const auto& kf : m.keyframes) {
      const Eigen::Vector3d c = kf.T_cam_world * pt.p_world;
      SlamMapObservation o;
      o.keyframe = kf.id;
      o.u_px = 500 * c.x() / c.z() + 320;
      o.v_px = 500 * c.y() / c.z() + 240;
      o.u_right_px = p % 2 ? o.u_px - 500 * 0.5 / c.z() : -1;
      pt.observations.push_back(o);
    }
    m.points.push_back(pt);
  }
  m.points[0].observations[1].u_px += 20;  // outlier
  m.points[1].observations[2].level = 5;   // coarse
  return m;
}

// Levels above 2 dropped, equal weights.
ObservationSelection UpToLevel2() {
  ObservationSelection sel;
  sel.max_level = 2;
  sel.level_weighting = false;
  return sel;
}

TEST(ColmapExport, ExactMapReprojectsToZeroAndDropsWhatTheRulesSay) {
  const SlamMapFile map = SyntheticMap();
  const ColmapExport ex = ExportToColmap(map, {1, 2, 3, 4}, UpToLevel2());
  EXPECT_EQ(ex.counts.observations, 120);
  EXPECT_EQ(ex.counts.dropped_outlier, 1);
  EXPECT_EQ(ex.counts.dropped_level, 1);
  EXPECT_EQ(ex.counts.kept_left, 118);
  EXPECT_EQ(ex.counts.kept_right, 15 * 4 - 1);  // odd points are stereo; point 1 lost one observation
  EXPECT_EQ(ex.counts.points_kept, 30);
  ASSERT_EQ(ex.model.images.size(), 8u);
  EXPECT_EQ(ex.model.images[0].name, "left/000001.png");
  EXPECT_EQ(ex.model.images[7].name, "right/000004.png");
  const ReprojectionStats s = ModelReprojection(ex.model);
  EXPECT_EQ(s.observations, 118 + 59);
  EXPECT_LT(s.rmse_px, 1e-9);  // the right camera = rig pose with the baseline
}

TEST(ColmapExport, PointsSeenByOneKeyframeAreLeftOut) {
  SlamMapFile map = SyntheticMap();
  map.points[5].observations.resize(1);
  const ColmapExport ex = ExportToColmap(map, {1, 2, 3, 4}, UpToLevel2());
  EXPECT_EQ(ex.counts.points_kept, 29);
  EXPECT_EQ(ex.counts.dropped_weak_point, 1);
  // Round trip of poses and points through the model.
  const auto poses = KeyframePosesFromModel(ex.model, ex);
  ASSERT_EQ(poses.size(), 4u);
  EXPECT_TRUE(poses.at(2).isApprox(map.keyframes[2].T_cam_world, 1e-12));
  const auto points = PointsFromModel(ex.model, ex);
  EXPECT_EQ(points.count(5), 0u);
  EXPECT_EQ(points.at(6), map.points[6].p_world);
}

// COLMAP's result floating by a rigid motion (the rig BA fixes no gauge) comes back exactly onto the
// SLAM poses, points and frames; a keyframe COLMAP had no image of follows its neighbours.
TEST(RestoreGauge, RigidlyMovedResultComesBackExactly) {
  SlamMapFile map = SyntheticMap();
  for (auto& p : map.points) p.observations.erase(p.observations.begin() + 2);  // keyframe 12: no observation
  for (bool weighted : {false, true}) {
  ObservationSelection sel;
  sel.level_weighting = weighted;
  const ColmapExport ex = ExportToColmap(map, {1, 2, 3, 4}, sel);
  ASSERT_EQ(ex.model.images.size(), 6u);
  Eigen::Isometry3d M = Eigen::Isometry3d::Identity();  // world motion of the whole solution
  M.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 1, 0.3).normalized()).toRotationMatrix();
  M.translation() = Eigen::Vector3d(3, -1, 2);
  ColmapModel moved = ex.problem;
  for (auto& im : moved.images) im.SetPose(im.T_cam_world() * M.inverse());
  for (auto& p : moved.points) p.xyz = M * p.xyz;
  Trajectory slam;  // frames between and beyond the keyframes (t_ns 1000..1003)
  for (int64_t t = 998; t <= 1005; ++t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.3 * (t - 1000), 0.01 * t - 10, 0);
    slam.poses.push_back({t, T});
  }
  for (GaugeAnchor anchor : {GaugeAnchor::kKeyframes, GaugeAnchor::kFirstKeyframe}) {
    const RefinedSurvey r = RestoreGauge(map, slam, ex, moved, anchor);
    for (size_t k = 0; k < map.keyframes.size(); ++k)
      EXPECT_TRUE(r.map.keyframes[k].T_cam_world.isApprox(map.keyframes[k].T_cam_world, 1e-9)) << k;
    for (size_t p = 0; p < map.points.size(); ++p) EXPECT_LT((r.map.points[p].p_world - map.points[p].p_world).norm(), 1e-9);
    for (size_t i = 0; i < slam.poses.size(); ++i)
      EXPECT_TRUE(r.trajectory.poses[i].T_world_frame.isApprox(slam.poses[i].T_world_frame, 1e-9)) << i;
    EXPECT_LT(r.max_keyframe_move_m, 1e-9);
    EXPECT_LT(ModelReprojection(r.colmap).rmse_px, 1e-6);
  }
  }
}

// Per-level cameras: an observation at level l and its residual are scaled by 1/1.2^l; the exact
// map still reprojects to zero; a residual of 1.2^l px at level l weighs 1 px.
TEST(ColmapExport, LevelWeightingWhitensResiduals) {
  SlamMapFile map = SyntheticMap();
  map.points[0].observations[1].u_px -= 20;  // no outlier this time
  for (size_t p = 0; p < map.points.size(); ++p) map.points[p].observations[0].level = int(p % 3);
  ObservationSelection sel;
  sel.level_weighting = true;
  sel.max_level = 7;
  ColmapExport ex = ExportToColmap(map, {1, 2, 3, 4}, sel);
  EXPECT_EQ(ex.images_per_keyframe, 16);
  EXPECT_EQ(ModelReprojection(ex.problem).observations, ModelReprojection(ex.model).observations);
  EXPECT_LT(ModelReprojection(ex.problem).rmse_px, 1e-9);
  // Move point 2's level-2 left observation by 1.44 px: 1 px in the problem, 1.44 px in the model.
  for (auto& im : ex.model.images)
    for (auto& o : im.points2d)
      if (im.id == 1 && o.point3d_id == 3) o.x += 1.44;
  for (auto& im : ex.problem.images)
    for (auto& o : im.points2d)
      if (im.camera_id == 5 && im.id == 1 + 4 && o.point3d_id == 3) o.x += 1.44 / 1.44;
  const auto m = ModelReprojection(ex.model), p = ModelReprojection(ex.problem);
  EXPECT_NEAR(m.rmse_px * m.rmse_px * m.observations, 1.44 * 1.44, 1e-9);
  EXPECT_NEAR(p.rmse_px * p.rmse_px * p.observations, 1.0, 1e-9);
  const auto poses = KeyframePosesFromModel(ex.problem, ex);
  ASSERT_EQ(poses.size(), 4u);
  EXPECT_TRUE(poses.at(3).isApprox(map.keyframes[3].T_cam_world, 1e-12));
}

// The right image's row repeats the left one's (rectified): in the weighted problem a 1 px row error
// in the right image weighs 1/1000^2 of a 1 px column error, so each stereo point's row counts once,
// as in the SLAM's (u_left, v, u_right) residual.
TEST(ColmapExport, RightImageRowCountsOnce) {
  ObservationSelection sel;
  sel.level_weighting = true;
  for (bool row : {true, false}) {
    ColmapExport ex = ExportToColmap(SyntheticMap(), {1, 2, 3, 4}, sel);
    ColmapImage* right = nullptr;  // keyframe 0's level-0 right image
    for (auto& im : ex.problem.images)
      if (im.camera_id == 2 && !im.points2d.empty()) right = &im;
    ASSERT_NE(right, nullptr);
    const ColmapCamera& cam = ex.problem.cameras[1];
    ASSERT_EQ(cam.id, 2u);
    // 1 px of the original image, in this camera's units (params: fx, fy, cx, cy).
    const double px = row ? cam.params[1] / SyntheticMap().camera.fy : cam.params[0] / SyntheticMap().camera.fx;
    (row ? right->points2d[0].y : right->points2d[0].x) += px;
    const auto r = ModelReprojection(ex.problem);
    EXPECT_NEAR(r.rmse_px * r.rmse_px * r.observations, row ? 1e-6 : 1.0, 1e-12) << (row ? "row" : "column");
  }
}

// Values that differ by solver noise (1e-15) round to the same bytes; the rounding moves nothing by
// more than half a step.
TEST(RoundModel, NoiseRoundsAway) {
  const ColmapExport ex = ExportToColmap(SyntheticMap(), {1, 2, 3, 4}, ObservationSelection{});
  ColmapModel a = ex.model, b = ex.model;
  for (auto& im : b.images) im.t_cam_world += Eigen::Vector3d::Constant(3e-15);
  for (auto& p : b.points) p.xyz -= Eigen::Vector3d::Constant(2e-15);
  RoundModel(&a, 1e-7);
  RoundModel(&b, 1e-7);
  EXPECT_EQ(ColmapImagesBinary(a.images), ColmapImagesBinary(b.images));
  EXPECT_EQ(ColmapPointsBinary(a.points), ColmapPointsBinary(b.points));
  for (size_t i = 0; i < a.points.size(); ++i) EXPECT_LE((a.points[i].xyz - ex.model.points[i].xyz).lpNorm<Eigen::Infinity>(), 0.5e-7 + 1e-15);
}

}  // namespace
}  // namespace rs
