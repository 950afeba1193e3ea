#include "stages/refine/colmap_export.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include <fmt/format.h>

namespace rs {
namespace {

// COLMAP puts the centre of the top-left pixel at (0.5, 0.5); the SLAM's rectified images at (0, 0).
constexpr double kColmapPixelShift = 0.5;

struct Residual {
  bool in_front = false;
  double chi2 = 0;  // squared residual over sigma², left u, v (and right u when stereo)
};

Residual SlamResidual(const SlamMapFile& map, const SlamMapKeyframe& kf, const Eigen::Vector3d& p_world,
                      const SlamMapObservation& o, bool with_right) {
  const auto& c = map.camera;
  const Eigen::Vector3d p = kf.T_cam_world * p_world;
  Residual r;
  if (p.z() <= 0) return r;
  r.in_front = true;
  const double u = c.fx * p.x() / p.z() + c.cx, v = c.fy * p.y() / p.z() + c.cy;
  double e2 = (u - o.u_px) * (u - o.u_px) + (v - o.v_px) * (v - o.v_px);
  if (with_right) {
    const double ur = u - c.fx * c.baseline_m / p.z();
    e2 += (ur - o.u_right_px) * (ur - o.u_right_px);
  }
  const double sigma = map.LevelSigmaPx(o.level);
  r.chi2 = e2 / (sigma * sigma);
  return r;
}

ColmapCamera Pinhole(uint32_t id, const SlamMapCamera& c) {
  return {id, "PINHOLE", static_cast<uint64_t>(c.width), static_cast<uint64_t>(c.height),
          {c.fx, c.fy, c.cx + kColmapPixelShift, c.cy + kColmapPixelShift}};
}

// A rectified pair measures a stereo point's row once: the right image's v is the left one's. The
// SLAM's stereo residual is (u_left, v, u_right); COLMAP's right observation would add v a second
// time and double its weight against u. The right cameras' rows are therefore scaled down by
// kRightRowScale (fy and cy with them), which leaves that second v a weight of 1/kRightRowScale^2.
constexpr double kRightRowScale = 1000;
double RowScale(int side) { return side == 1 ? kRightRowScale : 1.0; }

// The same observations with one camera per (side, level): pixels scaled by 1/sigma_level, so that
// an unweighted residual in that camera is the residual over its sigma.
void MakeLevelWeightedProblem(const SlamMapFile& map, int max_level, ColmapExport* ex) {
  const int levels = std::min(max_level, map.pyramid_levels - 1) + 1;
  ex->images_per_keyframe = 2 * levels;
  ColmapModel& out = ex->problem;
  out.cameras.clear();
  ColmapRig rig{kLeftCameraId, {}};
  for (int l = 0; l < levels; ++l) {
    const double s = map.LevelSigmaPx(l);
    for (int side = 0; side < 2; ++side) {
      const ColmapCamera& base = ex->model.cameras[side];
      ColmapCamera c = base;
      c.id = static_cast<uint32_t>(1 + 2 * l + side);
      const double sy = s * RowScale(side);
      c.params[0] /= s, c.params[2] /= s;
      c.params[1] /= sy, c.params[3] /= sy;
      c.width = static_cast<uint64_t>(std::ceil(base.width / s));
      c.height = static_cast<uint64_t>(std::max(1.0, std::ceil(base.height / sy)));
      out.cameras.push_back(c);
      const std::string prefix = std::string(side ? "right" : "left") + (l ? fmt::format("_level{}/", l) : "/");
      rig.cameras.push_back({c.id, prefix, ex->rigs.front().cameras[side].T_cam_rig});
    }
  }
  ex->problem_rigs = {rig};
  out.images.clear();
  out.points = ex->model.points;
  for (auto& p : out.points) p.track.clear();
  std::map<uint64_t, size_t> point_index;
  for (size_t k = 0; k < out.points.size(); ++k) point_index[out.points[k].id] = k;
  for (size_t i = 0; i < map.keyframes.size(); ++i) {
    for (int l = 0; l < levels; ++l)
      for (int side = 0; side < 2; ++side) {
        const ColmapImage& plain = ex->model.images[2 * i + side];
        ColmapImage im = plain;
        im.id = static_cast<uint32_t>(1 + ex->images_per_keyframe * i + 2 * l + side);
        im.camera_id = static_cast<uint32_t>(1 + 2 * l + side);
        im.name = rig.cameras[2 * l + side].image_prefix + plain.name.substr(plain.name.find('/') + 1);
        im.points2d.clear();
        const double s = map.LevelSigmaPx(l);
        for (size_t k = 0; k < plain.points2d.size(); ++k) {
          if (ex->level_of_point2d[plain.id - 1][k] != l) continue;
          const auto& o = plain.points2d[k];
          out.points[point_index.at(o.point3d_id)].track.push_back({im.id, static_cast<uint32_t>(im.points2d.size())});
          im.points2d.push_back({o.x / s, o.y / (s * RowScale(side)), o.point3d_id});
        }
        out.images.push_back(std::move(im));
      }
  }
}

}  // namespace

ColmapExport ExportToColmap(const SlamMapFile& map, const std::vector<int64_t>& frame_of_keyframe,
                            const ObservationSelection& sel) {
  if (!(map.camera.baseline_m > 0)) throw std::invalid_argument("the SLAM map's camera has no stereo baseline");
  if (frame_of_keyframe.size() != map.keyframes.size())
    throw std::invalid_argument("one frame id per keyframe expected");
  ColmapExport ex;
  ex.model.cameras = {Pinhole(kLeftCameraId, map.camera), Pinhole(kRightCameraId, map.camera)};
  // Right camera from rig (= left camera): x_right = x_left - (baseline, 0, 0).
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  T_right_left.translation() = Eigen::Vector3d(-map.camera.baseline_m, 0, 0);
  ex.rigs = {{kLeftCameraId, {{kLeftCameraId, "left/", Eigen::Isometry3d::Identity()}, {kRightCameraId, "right/", T_right_left}}}};

  std::map<int, int> index_of_keyframe;
  ex.level_of_point2d.resize(2 * map.keyframes.size());
  for (size_t i = 0; i < map.keyframes.size(); ++i) {
    const auto& kf = map.keyframes[i];
    index_of_keyframe[kf.id] = static_cast<int>(i);
    const std::string frame = fmt::format("{:06d}.png", frame_of_keyframe[i]);
    ColmapImage left, right;
    left.id = static_cast<uint32_t>(2 * i + 1);
    left.camera_id = kLeftCameraId;
    left.name = "left/" + frame;
    left.SetPose(kf.T_cam_world);
    right.id = static_cast<uint32_t>(2 * i + 2);
    right.camera_id = kRightCameraId;
    right.name = "right/" + frame;
    right.SetPose(T_right_left * kf.T_cam_world);
    ex.model.images.push_back(left);
    ex.model.images.push_back(right);
    ex.keyframe_of_left_image.push_back(static_cast<int>(i));
  }

  for (size_t pi = 0; pi < map.points.size(); ++pi) {
    const SlamMapPoint& point = map.points[pi];
    std::vector<const SlamMapObservation*> kept;
    std::set<int> keyframes;
    for (const auto& o : point.observations) {
      ++ex.counts.observations;
      if (o.level > sel.max_level) {
        ++ex.counts.dropped_level;
        continue;
      }
      const bool with_right = sel.stereo && o.u_right_px >= 0;
      const Residual r = SlamResidual(map, map.keyframes[index_of_keyframe.at(o.keyframe)], point.p_world, o, with_right);
      if (!r.in_front || r.chi2 > (with_right ? sel.chi2_stereo : sel.chi2_mono)) {
        ++ex.counts.dropped_outlier;
        continue;
      }
      kept.push_back(&o);
      keyframes.insert(o.keyframe);
    }
    if (static_cast<int>(keyframes.size()) < sel.min_keyframes || kept.empty()) {
      ex.counts.dropped_weak_point += static_cast<int64_t>(kept.size());
      ++ex.counts.points_dropped;
      continue;
    }
    ColmapPoint3D p;
    p.id = ex.map_point_of_colmap_point.size() + 1;
    p.xyz = point.p_world;
    ex.map_point_of_colmap_point.push_back(static_cast<int>(pi));
    for (const SlamMapObservation* o : kept) {
      const int k = index_of_keyframe.at(o->keyframe);
      auto add = [&](ColmapImage& im, double u) {
        p.track.push_back({im.id, static_cast<uint32_t>(im.points2d.size())});
        im.points2d.push_back({u + kColmapPixelShift, o->v_px + kColmapPixelShift, p.id});
        ex.level_of_point2d[im.id - 1].push_back(o->level);
      };
      add(ex.model.images[2 * k], o->u_px);
      ++ex.counts.kept_left;
      if (sel.stereo && o->u_right_px >= 0) {
        add(ex.model.images[2 * k + 1], o->u_right_px);
        ++ex.counts.kept_right;
      }
    }
    ex.model.points.push_back(std::move(p));
    ++ex.counts.points_kept;
  }
  if (sel.level_weighting) {
    MakeLevelWeightedProblem(map, sel.max_level, &ex);
  } else {
    ex.problem = ex.model;
    ex.problem_rigs = ex.rigs;
  }
  // COLMAP's bundle adjuster aborts on an image (or a camera) without observations: such images are
  // left out; their keyframes then follow their neighbours (RestoreGauge).
  for (ColmapModel* m : {&ex.model, &ex.problem}) {
    std::erase_if(m->images, [](const ColmapImage& im) { return im.points2d.empty(); });
    std::erase_if(m->cameras, [&](const ColmapCamera& c) {
      return std::none_of(m->images.begin(), m->images.end(), [&](const auto& im) { return im.camera_id == c.id; });
    });
  }
  std::erase_if(ex.rigs.front().cameras, [&](const auto& c) { return !ex.model.FindCamera(c.camera_id); });
  std::erase_if(ex.problem_rigs.front().cameras, [&](const auto& c) { return !ex.problem.FindCamera(c.camera_id); });
  return ex;
}

ReprojectionStats ModelReprojection(const ColmapModel& model) {
  std::map<uint64_t, const ColmapPoint3D*> points;
  for (const auto& p : model.points) points[p.id] = &p;
  ReprojectionStats s;
  double sum2 = 0;
  for (const auto& im : model.images) {
    const ColmapCamera* cam = model.FindCamera(im.camera_id);
    if (!cam || cam->model != "PINHOLE") throw std::invalid_argument("only PINHOLE cameras are scored");
    const auto& k = cam->params;
    const Eigen::Isometry3d T = im.T_cam_world();
    for (const auto& o : im.points2d) {
      if (o.point3d_id == kColmapNoPoint3D) continue;
      const Eigen::Vector3d p = T * points.at(o.point3d_id)->xyz;
      const double du = k[0] * p.x() / p.z() + k[2] - o.x, dv = k[1] * p.y() / p.z() + k[3] - o.y;
      sum2 += du * du + dv * dv;
      ++s.observations;
    }
  }
  s.rmse_px = s.observations ? std::sqrt(sum2 / s.observations) : 0;
  return s;
}

std::map<int, Eigen::Isometry3d> KeyframePosesFromModel(const ColmapModel& model, const ColmapExport& ex) {
  std::map<int, Eigen::Isometry3d> out;
  // Every left image of a keyframe (any level) has the rig's pose.
  for (const auto& im : model.images) {
    const size_t i = (im.id - 1) / ex.images_per_keyframe;
    if ((im.id - 1) % 2 != 0 || i >= ex.keyframe_of_left_image.size()) continue;
    out[ex.keyframe_of_left_image[i]] = im.T_cam_world();
  }
  return out;
}

std::map<int, Eigen::Vector3d> PointsFromModel(const ColmapModel& model, const ColmapExport& ex) {
  std::map<int, Eigen::Vector3d> out;
  for (const auto& p : model.points)
    if (p.id >= 1 && p.id <= ex.map_point_of_colmap_point.size()) out[ex.map_point_of_colmap_point[p.id - 1]] = p.xyz;
  return out;
}

}  // namespace rs
