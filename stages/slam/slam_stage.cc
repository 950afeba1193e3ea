#include "stages/slam/slam_stage.h"

#include <GeographicLib/LocalCartesian.hpp>
#include <fmt/format.h>

#include <deque>

#include <chrono>
#include <sstream>
#include <tuple>

#include "formats/checked_file.h"
#include "formats/frame_priors.h"
#include "formats/slam_map/slam_map_file.h"
#include "formats/stereo/calibration_yaml.h"
#include "formats/stereo/pair_prefetch.h"
#include "formats/trajectory/tum_trajectory.h"
#include "stages/slam/slam_pipeline.h"
#include "stages/slam/stereo_slam.h"
#include "survey/atomic_file.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

const OptionTable<SlamOptions>& SlamTable() {
  static const auto t =
      OptionTable<SlamOptions>()
          .AddEnum(
              "regime", &SlamOptions::regime,
              {{"auto", SlamRegime::kAuto}, {"forward", SlamRegime::kForward}, {"nadir", SlamRegime::kNadir}},
              "geometry regime: forward (car) sets features, triangulation, local BA and keyframe gap; nadir "
              "(drone) keeps the options as given; auto chooses by the first frames' stereo depth range and motion")
          .Add("features", &SlamOptions::features, "ORB features kept per image after grid spreading")
          .Min(100)
          .Add("pyramid_levels", &SlamOptions::pyramid_levels, "scale pyramid levels")
          .Min(1)
          .Add("scale_factor", &SlamOptions::scale_factor, "scale ratio between pyramid levels")
          .Above(1)
          .Add("fast_threshold", &SlamOptions::fast_threshold, "FAST threshold", "grey levels")
          .Min(1)
          .Add("grid_cell_px", &SlamOptions::grid_cell_px, "cell size of the feature-spreading grid", "px")
          .Min(4)
          .Add("close_depth_baselines", &SlamOptions::close_depth_baselines,
               "a stereo point is close (reliable depth) below this many baselines")
          .Above(0)
          .Add("min_close_points", &SlamOptions::min_close_points,
               "when fewer than 100 stereo points are close (a nadir view from altitude), the nearest this many count "
               "as close")
          .Min(0)
          .Add("stereo_max_hamming", &SlamOptions::stereo_max_hamming, "largest left-right descriptor distance")
          .Min(0)
          .Max(256)
          .Add("disparity_offset_px", &SlamOptions::disparity_offset_px,
               "added to every measured disparity: residual rectification error (KITTI: ~0.23, measured against LiDAR)",
               "px")
          .Min(-5)
          .Max(5)
          .Add("disparity_self_calibration", &SlamOptions::disparity_self_calibration,
               "at the end, add the disparity offset the keyframes' own motion implies (when known to 0.03 px) to "
               "every stereo measurement before the global BA")
          .Add("match_max_hamming", &SlamOptions::match_max_hamming, "largest frame-to-map descriptor distance")
          .Min(0)
          .Max(256)
          .Add("match_ratio", &SlamOptions::match_ratio, "best / second-best distance ratio")
          .Above(0)
          .Max(1)
          .Add("search_radius_px", &SlamOptions::search_radius_px,
               "search radius when projecting the previous frame's points (x pyramid scale)", "px")
          .Above(0)
          .Add("min_tracked_inliers", &SlamOptions::min_tracked_inliers, "fewer inliers = tracking lost")
          .Min(3)
          .Add("keyframe_max_gap", &SlamOptions::keyframe_max_gap, "a keyframe at least every this many frames")
          .Min(1)
          .Add("keyframe_tracked_ratio", &SlamOptions::keyframe_tracked_ratio,
               "keyframe when inliers < ratio x points tracked by the reference keyframe")
          .Above(0)
          .Max(1)
          .Add("local_ba_keyframes", &SlamOptions::local_ba_keyframes, "keyframes in each local bundle adjustment")
          .Min(1)
          .Add("local_ba_iterations", &SlamOptions::local_ba_iterations, "solver iterations of each local BA")
          .Min(1)
          .Add("local_ba_fixed_size", &SlamOptions::local_ba_fixed_size,
               "local BA by the fixed-size Schur Levenberg-Marquardt instead of Ceres (~5x less CPU; same minimum, "
               "other rounding)")
          .Add("local_map_keyframes", &SlamOptions::local_map_keyframes, "keyframes whose points form the local map")
          .Min(1)
          .Add("triangulation_neighbours", &SlamOptions::triangulation_neighbours,
               "covisible keyframes matched with each new keyframe to triangulate new points (0: off; 10 = ORB-SLAM2)")
          .Min(0)
          .Add("loop_closure", &SlamOptions::loop_closure, "detect and close loops, then a global bundle adjustment")
          .Add("vocabulary_branching", &SlamOptions::vocabulary_branching, "bag-of-words vocabulary tree branching")
          .Min(2)
          .Add("vocabulary_depth", &SlamOptions::vocabulary_depth, "bag-of-words vocabulary tree depth")
          .Min(1)
          .Add("loop_min_gap_keyframes", &SlamOptions::loop_min_gap_keyframes,
               "a loop candidate must be at least this many keyframes older")
          .Min(1)
          .Add("loop_min_inliers", &SlamOptions::loop_min_inliers, "stereo SE(3) RANSAC inliers to accept a loop")
          .Min(3)
          .Add("loop_prior_radius_m", &SlamOptions::loop_prior_radius_m,
               "keyframes whose priors lie within this distance are loop candidates", "m")
          .Min(0)
          .Add("loop_prior_gate_m", &SlamOptions::loop_prior_gate_m,
               "reject a loop whose relative translation disagrees with the priors by more", "m")
          .Min(0)
          .Add("global_ba_iterations", &SlamOptions::global_ba_iterations, "solver iterations of the global BA")
          .Min(0)
          .Add("global_ba_frames", &SlamOptions::global_ba_frames,
               "the global BA also optimises every tracked frame with its map-point matches")
          .Add("global_ba_disparity_sigma_px", &SlamOptions::global_ba_disparity_sigma_px,
               "stereo disparity sigma in the global BA (0: the right image's u at the keypoint's sigma)", "px")
          .Min(0)
          .Add("ransac_seed", &SlamOptions::ransac_seed, "seed of every RANSAC (same input and seed, same result)")
          .Add("parallel", &SlamOptions::parallel,
               "extract the next frames' features on two threads while a frame is tracked (result unchanged)");
  return t;
}

// Position priors in a local ENU frame at the first frame with a GNSS fix.
std::vector<std::optional<PosePrior>> MakePriors(const std::vector<FrameRecord>& frames,
                                                 const std::vector<FramePrior>& priors, double default_sigma_m) {
  std::map<int64_t, const FramePrior*> by_id;
  for (const auto& p : priors) by_id[p.id.value] = &p;
  std::optional<GeographicLib::LocalCartesian> enu;
  std::vector<std::optional<PosePrior>> out;
  for (const auto& f : frames) {
    const auto it = by_id.find(f.id.value);
    if (it == by_id.end() || it->second->status != PriorStatus::kOk) {
      out.emplace_back();
      continue;
    }
    const FramePrior& p = *it->second;
    const double h = std::isnan(p.alt_m) ? 0.0 : p.alt_m;
    if (!enu) enu.emplace(p.lat_deg, p.lon_deg, h);
    double x, y, z;
    enu->Forward(p.lat_deg, p.lon_deg, h, x, y, z);
    PosePrior prior;
    prior.T_world_cam = Eigen::Isometry3d::Identity();
    prior.T_world_cam.translation() = Eigen::Vector3d(x, y, z);
    prior.has_position = true;
    prior.has_attitude = false;  // camera-to-body mounting is not known here
    prior.sigma_position_m = std::isnan(p.h_acc_m) ? default_sigma_m : std::max(0.01, p.h_acc_m);
    out.push_back(prior);
  }
  return out;
}

// Reads a frame's pair; a frame whose images are missing or unreadable is skipped (by id and
// reason, see StageContext::SkipFrame) and the trajectory goes on without it.
bool NextPairOrSkip(StageContext& ctx, const FrameRecord& f, StereoPairPrefetcher& images, cv::Mat* left,
                    cv::Mat* right) {
  try {
    std::tie(*left, *right) = images.Next();
    return true;
  } catch (const InputError& e) {
    ctx.SkipFrame(f.id, e.message(), e.where().ToString());
    return false;
  }
}

// The map as later stages read it (formats/slam_map): good keyframes and points, every observation
// with its pyramid level and stereo match, so a re-adjustment can weight it as the SLAM did.
SlamMapFile ToMapFile(const SlamMap& map, const RectifiedStereo& camera, const SlamOptions& options) {
  SlamMapFile out;
  out.camera = {camera.width, camera.height, camera.f_px, camera.f_px, camera.cx_px, camera.cy_px, camera.baseline_m};
  out.scale_factor = options.scale_factor;
  out.pyramid_levels = options.pyramid_levels;
  for (const auto& k : map.keyframes) {
    if (k.bad) continue;
    out.keyframes.push_back({k.id, k.t_ns, k.segment, k.T_cam_world});
  }
  for (const auto& p : map.points) {
    if (p.bad) continue;
    SlamMapPoint pt{p.id, p.p_world, {}};
    for (const auto& [kf_id, feature] : p.observations) {
      const Keyframe& k = map.keyframes[kf_id];
      if (k.bad) continue;
      const auto& kp = k.features.keypoints[feature];
      pt.observations.push_back({kf_id, kp.pt.x, kp.pt.y, kp.octave, k.features.u_right[feature]});
    }
    out.points.push_back(std::move(pt));
  }
  return out;
}

}  // namespace

void SlamStageOptions::Check() const { slam.Check(); }

const OptionTable<SlamStageOptions>& SlamStageOptions::Table() {
  static const auto t = OptionTable<SlamStageOptions>()
                            .Include("", &SlamStageOptions::slam, SlamTable())
                            .Add("use_gnss_priors", &SlamStageOptions::use_gnss_priors,
                                 "use each frame's GNSS position (from the flight log) as a prior")
                            .Add("default_prior_sigma_m", &SlamStageOptions::default_prior_sigma_m,
                                 "GNSS position sigma when the log gives no accuracy", "m")
                            .Above(0);
  return t;
}

StageInfo SlamStage::Info() {
  StageInfo info;
  info.name = "slam";
  // 5: frames held by stereo odometry instead of lost; 4: map observations carry pyramid level and stereo match
  info.version = 5;
  info.doc =
      "Stereo visual SLAM (ORB features, stereo depth, motion-only and local bundle adjustment, loop "
      "closing, global BA) over the frames in time order, GNSS positions as priors.";
  info.inputs = {"frames", "calibration", "priors"};
  info.outputs = {"trajectory", "map"};
  info.published = {{"trajectory.tum", "trajectory.tum"}, {"keyframes.tum", "keyframes.tum"}};
  info.per_frame = true;  // its result depends on the frame selection
  return info;
}

void SlamStage::Run(StageContext& ctx, const SlamStageOptions& o) const {
  const auto all = ReadFrameIndex(ctx.input_dir("frames") / "frames.csv");
  std::vector<FrameRecord> frames;
  for (const auto& f : all)
    if (ctx.frame_selection().Contains(f.id.value)) frames.push_back(f);
  const StereoCalibration calib = ReadCalibrationYaml(ctx.input_dir("calibration") / "calibration.yaml");
  const auto priors =
      o.use_gnss_priors
          ? MakePriors(frames, ReadFramePriors(ctx.input_dir("priors") / "frame_priors.csv"), o.default_prior_sigma_m)
          : std::vector<std::optional<PosePrior>>(frames.size());

  StereoSlam slam(calib, o.slam);
  ctx.progress().Start("slam", static_cast<int64_t>(frames.size()));
  std::ostringstream status;  // written once complete, through the checked writer
  // position: how the frame's pose was found - "visual" (tracked or relocalised), "gnss" (lost; placed
  // mostly by the flight log's displacement) or "motion-model" (lost; constant-velocity prediction).
  status << "frame_id,t_ns,status,position,segment,features,stereo_features,inliers,keyframe\n";
  std::map<std::string, int> by_status;
  // Later frames' features are extracted while a frame is tracked (o.slam.parallel; same results):
  // Push returns the result of an earlier pushed frame, Flush the rest; `pushed` holds the frames
  // whose results are still to come, in order.
  SlamPipeline pipeline(&slam, o.slam.parallel);
  std::deque<size_t> pushed;
  auto record = [&](const FrameResult& r) {
    const auto& f = frames[pushed.front()];
    pushed.pop_front();
    const char* position = r.status != FrameStatus::kPriorOnly ? "visual"
                           : r.gnss_weight >= 0.5              ? "gnss"
                                                               : "motion-model";
    status << fmt::format("{},{},{},{},{},{},{},{},{}\n", f.id.value, f.t_ns, ToString(r.status), position, r.segment,
                          r.features, r.stereo_features, r.inliers, r.keyframe ? 1 : 0);
    ++by_status[ToString(r.status)];
    ctx.progress().Advance();
  };
  int64_t skipped = 0;
  // Pairs are decoded a few frames ahead on worker threads: memory stays flat however long the survey.
  std::vector<StereoPairFiles> files;
  for (const FrameRecord& f : frames) files.push_back({f.left, f.right});
  StereoPairPrefetcher images(std::move(files), kSlamDecodeAheadPairs);
  for (size_t i = 0; i < frames.size(); ++i) {
    cv::Mat left, right;
    if (!NextPairOrSkip(ctx, frames[i], images, &left, &right)) {
      ++skipped;
      ctx.progress().Advance();
      continue;
    }
    pushed.push_back(i);
    if (const auto r = pipeline.Push(frames[i].t_ns, left, right, priors[i])) record(*r);
  }
  for (const FrameResult& r : pipeline.Flush()) record(r);
  ctx.progress().Finish();
  const SlamResult result = slam.Finish();

  WriteFileChecked(ctx.out_dir() / "frame_status.csv", status.view());
  WriteTumTrajectory(ctx.out_dir() / "trajectory.tum", result.frames);
  WriteTumTrajectory(ctx.out_dir() / "keyframes.tum", result.keyframes);
  WriteSlamMap(ctx.out_dir() / "map", ToMapFile(result.map, slam.camera(), slam.options()));
  const auto& s = result.stats;
  ctx.summary().frames_total = static_cast<int64_t>(frames.size());
  ctx.summary().frames_computed = static_cast<int64_t>(frames.size()) - skipped;
  for (const auto& [k, v] : by_status) ctx.Count("frames_" + k, v);
  // Which regime the first frames chose and why (slam_regime.h).
  ctx.summary().counts["regime"] = s.regime_reason;
  ctx.Count("keyframes", s.keyframes);
  ctx.Count("map_points", s.map_points);
  ctx.Count("frames_gnss_positioned", s.gnss_positioned);
  ctx.Count("frames_held_by_odometry", s.held_by_odometry);
  ctx.Count("segments", s.segments);
  ctx.Count("loops_closed", s.loops_closed);
  ctx.Count("loop_candidates", s.loop_candidates);
  ctx.Time("track", s.track_s);
  ctx.Time("finish", s.finish_s);
  if (s.prior_only > 0)
    ctx.Warn(
        fmt::format("{} frame(s) not placed visually (tracking lost), {} of them mostly by the GNSS prior: see "
                    "frame_status.csv",
                    s.prior_only, s.gnss_positioned));
  WriteJsonAtomic(ctx.out_dir() / "slam.json", {{"report", s.BriefReport()}, {"statuses", by_status}});
}

}  // namespace rs
