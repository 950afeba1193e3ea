// StereoSlam's public entry points and orchestration: construction, Track (the per-frame sequence of
// tracking, keyframe decision and loss handling), Finish (loop closing, global BA, results) and statistics.
// The steps themselves: stereo_slam_tracking.cc, stereo_slam_mapping.cc, stereo_slam_loss.cc.
#include "stages/slam/stereo_slam.h"

#include <atomic>
#include <future>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "stages/slam/disparity_calibration.h"
#include "stages/slam/global_refinement.h"
#include "stages/slam/loop_closing.h"
#include "stages/slam/slam_regime.h"
#include "stages/slam/stereo_slam_internal.h"

namespace rs {

const char* ToString(FrameStatus status) {
  switch (status) {
    case FrameStatus::kTracked: return "tracked";
    case FrameStatus::kRelocalised: return "relocalised";
    case FrameStatus::kPriorOnly: return "prior-only";
  }
  return "?";
}

std::string SlamStatistics::BriefReport() const {
  return fmt::format(
      "regime {}, {} frames ({} tracked of which {} held by odometry, {} relocalised, {} prior-only of which {} "
      "GNSS-positioned), {} keyframes, {} points, {} segments, {} loops closed ({} rejected of {} candidates)",
      ToString(regime), frames, tracked, held_by_odometry, relocalised, prior_only, gnss_positioned, keyframes,
      map_points, segments, loops_closed, loops_rejected, loop_candidates);
}

using stereo_slam_internal::Clock;
using stereo_slam_internal::Seconds;

// The disparity offset the keyframes' own motion implies (disparity_calibration.h), over the whole
// tracked map before loop closing (shorter windows scatter beyond their error); SlamStatistics, and
// applied by ApplyDisparitySelfCalibration when certain.
void StereoSlam::Impl::EstimateDisparityOffsetOfMap() {
  const DisparityOffsetEstimate e = EstimateMapDisparityOffset(map, cam);
  stats.disparity_offset_px = e.offset_px;
  stats.disparity_offset_sigma_px = e.sigma_px;
  stats.disparity_offset_samples = e.samples;
}

// The regime (slam_regime.h) from the first frame's features, once. True when the front end's options
// changed (the frame's features should be extracted again).
bool StereoSlam::Impl::ChooseRegimeFrom(const StereoFeatures& first) {
  if (regime_started) return false;
  regime_started = true;
  regime = ChooseRegimeFromDepths(opt, first);
  return ApplyRegime();
}

// A shallow first view: the regime from the camera's motion relative to the first frame.
void StereoSlam::Impl::DecideRegimeAfter(const TrackFrame& cur, FrameStatus status) {
  if (regime.decided || cur.index < 1) return;
  Eigen::Vector3d t = Eigen::Vector3d::Zero();  // a lost frame or another segment has no motion to judge
  if (status != FrameStatus::kPriorOnly && segment == 0)
    t = map.keyframes[0].T_cam_world * cur.T_cam_world.inverse().translation();
  if (DecideRegimeFromMotion(&regime, t, cur.index)) ApplyRegime();
}

// Records the regime; once decided, the options follow it (for the frames after this one).
bool StereoSlam::Impl::ApplyRegime() {
  stats.regime = regime.regime;
  stats.regime_reason = regime.reason;
  if (!regime.decided) return false;
  const SlamOptions chosen = OptionsForRegime(opt, regime.regime);
  const bool front_end_changed = chosen.features != opt.features;
  opt = chosen;
  return front_end_changed;
}

FrameResult StereoSlam::Impl::Track(int64_t t_ns, const cv::Mat& left, const cv::Mat& right,
                                    const std::optional<PosePrior>& prior) {
  if (finished) throw std::invalid_argument("StereoSlam::Track called after Finish");
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.cols != cam.width || left.rows != cam.height ||
      right.size() != left.size())
    throw std::invalid_argument(
        fmt::format("StereoSlam::Track: expected two 8-bit grey {}x{} images, got {}x{} and {}x{}", cam.width,
                    cam.height, left.cols, left.rows, right.cols, right.rows));
  const auto t0 = Clock::now();
  StereoFeatures f = ExtractStereoFeatures(left, right, cam, opt, pyr);
  if (ChooseRegimeFrom(f)) f = ExtractStereoFeatures(left, right, cam, opt, pyr);
  stats.track_s += Seconds(t0);
  return Track(t_ns, std::move(f), prior);
}

FrameResult StereoSlam::Impl::Track(int64_t t_ns, StereoFeatures features, const std::optional<PosePrior>& prior) {
  if (finished) throw std::invalid_argument("StereoSlam::Track called after Finish");
  if (!records.empty() && t_ns <= records.back().t_ns)
    throw std::invalid_argument(
        fmt::format("StereoSlam::Track: time {} ns does not follow {} ns", t_ns, records.back().t_ns));
  const auto t0 = Clock::now();
  ChooseRegimeFrom(features);
  TrackFrame cur;
  cur.index = static_cast<int>(records.size());
  cur.t_ns = t_ns;
  cur.prior = prior;
  cur.f = std::move(features);
  if (cur.f.grid.empty()) cur.f.BuildGrid(cam.width, cam.height);
  cur.close_depth_m = CloseDepthLimit(cur.f);
  cur.Reset(cur.f.size());
  FrameResult result;
  result.index = cur.index;
  result.t_ns = t_ns;
  result.features = static_cast<int>(cur.f.size());
  for (float d : cur.f.depth_m) result.stereo_features += d > 0;

  FrameStatus status = FrameStatus::kTracked;
  if (map.keyframes.empty()) {
    CreateKeyframe(&cur, true);
    result.keyframe = true;
  } else {
    UpdateLastFrame();
    // Prediction: constant velocity; without one, the prior's relative motion; else the last pose.
    bool has_motion = true;
    if (has_velocity) {
      cur.T_cam_world = velocity * last.T_cam_world;
    } else if (prior && last.prior && prior->has_position && prior->has_attitude && last.prior->has_attitude) {
      cur.T_cam_world = (last.prior->T_world_cam.inverse() * prior->T_world_cam).inverse() * last.T_cam_world;
    } else {
      cur.T_cam_world = last.T_cam_world;
      has_motion = false;
    }
    Eigen::Isometry3d predicted = cur.T_cam_world;
    // After a lost frame: extrapolate the last visually placed frames (and the flight log) instead.
    if (records.back().status == FrameStatus::kPriorOnly) {
      PlaceLostFrame(&cur);
      predicted = cur.T_cam_world;
    }
    bool ok = false;
    if (records.back().status == FrameStatus::kPriorOnly && has_velocity) {
      // After a dropout (frames placed by prediction) the previous frame has no points to match, and
      // descriptor matching against the reference keyframe over a partial overlap of a narrow nadir
      // view locked 0.5 m off along track in a test: search the reference keyframe's local map from
      // the extrapolation (good to centimetres over a few frames) in a wide window first.
      ok = TrackLocalMap(&cur, 3.0) >= opt.min_tracked_inliers;
      if (!ok) {
        cur.T_cam_world = predicted;
        cur.Reset(cur.f.size());
      }
    }
    // Without a motion prediction a projection search would lock onto wrong neighbours of a
    // fast-moving scene (KITTI moves 1.2 m per frame): match descriptors against the reference
    // keyframe first.
    if (!ok && !has_motion) {
      ok = TrackReferenceKeyframe(&cur);
      if (!ok) cur.T_cam_world = predicted;
    }
    if (!ok) ok = TrackWithMotionModel(&cur);
    if (!ok) {
      cur.T_cam_world = predicted;
      ok = TrackReferenceKeyframe(&cur);
    }
    if (!ok) {
      cur.T_cam_world = predicted;
      ok = Relocalise(&cur);
      if (ok) status = FrameStatus::kRelocalised;
    }
    int inliers = 0;
    bool held_by_odometry = false;
    if (ok) {
      inliers = TrackLocalMap(&cur, status == FrameStatus::kRelocalised ? 3.0 : 1.0);
      ok = inliers >= opt.min_tracked_inliers;
      // Few map points but many of the previous frame's stereo points (a fast view that keeps
      // little of the last keyframe: a car's road 3 m ahead, a turn): the pose is as well measured
      // as stereo odometry makes it, so the frame is tracked and becomes a keyframe at once, which
      // puts its stereo points into the map for the next frame. The bar is the weak-frame one of the
      // keyframe decision (3 x min_tracked_inliers).
      if (!ok && status == FrameStatus::kTracked && cur.all_inliers >= 3 * opt.min_tracked_inliers) {
        ok = held_by_odometry = true;
        ++stats.held_by_odometry;
      }
    }
    if (!ok && status == FrameStatus::kTracked) {
      cur.T_cam_world = predicted;
      cur.Reset(cur.f.size());
      if (Relocalise(&cur)) {
        status = FrameStatus::kRelocalised;
        inliers = TrackLocalMap(&cur, 3.0);
        ok = inliers >= opt.min_tracked_inliers;
      }
    }
    if (ok) {
      result.inliers = inliers;
      // Relocalised into another map segment (an older map re-found after a loss): continue in it.
      segment = map.keyframes[ref_kf].segment;
      if (held_by_odometry || NeedKeyframe(cur, inliers)) {
        CreateKeyframe(&cur, false);
        result.keyframe = true;
      }
    } else {
      // Lost: the prediction, seeded by the flight log (PlaceLostFrame), and a new map segment from
      // this frame's stereo points; Finish() links the segments (sequential pose-graph edge, loops)
      // and optimises them together. A frame with too few points to track against (blank, blurred)
      // seeds none: the next frame tries the old map again.
      status = FrameStatus::kPriorOnly;
      cur.T_cam_world = predicted;
      cur.Reset(cur.f.size());
      result.gnss_weight = PlaceLostFrame(&cur);
      if (result.stereo_features >= 3 * opt.min_tracked_inliers) {
        ++segment;
        ++stats.segments;
        CreateKeyframe(&cur, true);
        result.keyframe = true;
      }
    }
    // The velocity only from two visually placed frames of one segment (a predicted pose or a jump
    // between segments is no motion).
    if (ok && records.back().status != FrameStatus::kPriorOnly && records.back().segment == segment) {
      velocity = cur.T_cam_world * last.T_cam_world.inverse();
      has_velocity = true;
    }
  }
  FrameRecord rec;
  rec.t_ns = t_ns;
  rec.ref_kf = ref_kf;
  rec.T_cam_ref = cur.T_cam_world * map.keyframes[ref_kf].T_cam_world.inverse();
  rec.status = status;
  rec.segment = segment;
  if (prior && prior->has_position) rec.p_prior = prior->T_world_cam.translation();
  // A keyframe's matches are in the map already; a tracked frame's join the final global BA
  // (global_ba_frames) or re-solve its pose against the final map (RefineFramesOnFinalMap).
  if (status != FrameStatus::kPriorOnly && !result.keyframe) {
    for (size_t i = 0; i < cur.f.size(); ++i) {
      if (cur.mp[i] < 0) continue;
      const cv::KeyPoint& kp = cur.f.keypoints[i];
      rec.observations.push_back({kp.pt.x, kp.pt.y, cur.f.u_right[i], kp.octave, cur.mp[i]});
    }
  }
  records.push_back(std::move(rec));
  ++stats.frames;
  if (status == FrameStatus::kTracked) ++stats.tracked;
  if (status == FrameStatus::kRelocalised) ++stats.relocalised;
  if (status == FrameStatus::kPriorOnly) ++stats.prior_only;
  if (status == FrameStatus::kPriorOnly && result.gnss_weight >= 0.5) ++stats.gnss_positioned;
  result.status = status;
  result.segment = segment;
  result.T_world_cam = cur.T_cam_world.inverse();
  DecideRegimeAfter(cur, status);
  last = std::move(cur);
  has_last = true;
  stats.track_s += Seconds(t0);
  return result;
}

StereoSlam::Impl::GlobalBaRun StereoSlam::Impl::RunGlobalBa(SlamMap start, const std::atomic<bool>* cancel) const {
  GlobalBaRun run;
  run.map = std::move(start);
  // Keyframes, and with global_ba_frames every tracked frame (global_refinement.h).
  for (size_t i = 0; i < records.size() && opt.global_ba_frames; ++i) {
    const FrameRecord& r = records[i];
    if (r.observations.empty()) continue;
    RefinedFrame f;
    f.T_cam_world = r.T_cam_ref * run.map.keyframes[r.ref_kf].T_cam_world;
    f.observations = r.observations;
    run.frames.push_back(std::move(f));
    run.record_of.push_back(i);
  }
  GlobalBundleAdjustWithFrames(&run.map, &run.frames, cam, pyr, opt.global_ba_iterations, {0},
                               opt.global_ba_disparity_sigma_px, 10, cancel);
  return run;
}

SlamResult StereoSlam::Impl::Finish() {
  if (finished) throw std::invalid_argument("StereoSlam::Finish called twice");
  finished = true;
  const auto t0 = Clock::now();
  SlamResult out;
  EstimateDisparityOffsetOfMap();
  // The offset the map implies, applied to every stereo measurement before the global BA (stereo_slam_calibration.cc).
  if (opt.disparity_self_calibration) ApplyDisparitySelfCalibration();
  if (map.keyframes.size() >= 2) {
    const bool global_ba = opt.global_ba_iterations > 0;
    // The global BA of the map as it stands is the answer whenever no loop closes. With threads it runs on a
    // copy alongside loop detection, kept if no loop closes, else cancelled (at the first verified loop)
    // and run again on the corrected map: the same result as one after the other, in less wall time.
    std::atomic<bool> cancel{false};
    std::future<GlobalBaRun> speculative;
    if (global_ba && opt.loop_closure && opt.parallel) {
      speculative = std::async(std::launch::async,
                               [this, &cancel, copy = map]() mutable { return RunGlobalBa(std::move(copy), &cancel); });
    }
    std::vector<LoopClosure> loops;
    try {
      if (opt.loop_closure) loops = DetectAndCloseLoops(&map, cam, pyr, opt, &stats, &cancel);
    } catch (...) {
      cancel = true;
      if (speculative.valid()) speculative.wait();
      throw;
    }
    out.loops = loops;
    if (global_ba) {
      std::optional<GlobalBaRun> run;
      if (speculative.valid() && loops.empty() && !cancel) {
        run = speculative.get();  // rethrows what the BA threw
      } else if (speculative.valid()) {
        cancel = true;
        try {
          speculative.get();  // the loops moved the map: what that BA found (or threw) no longer applies
        } catch (...) {}
      }
      if (!run) run = RunGlobalBa(std::move(map), nullptr);
      map = std::move(run->map);
      // A refined frame's pose is kept relative to its reference keyframe, as the output below reads it.
      for (size_t j = 0; j < run->frames.size(); ++j) {
        FrameRecord& r = records[run->record_of[j]];
        if (run->frames[j].refined)
          r.T_cam_ref = run->frames[j].T_cam_world * map.keyframes[r.ref_kf].T_cam_world.inverse();
      }
    }
    if (!opt.global_ba_frames) RefineFramesOnFinalMap();
  }
  out.frames.source = "StereoSlam";
  for (size_t i = 0; i < records.size(); ++i) {
    const FrameRecord& r = records[i];
    StampedPose sp;
    sp.t_ns = r.t_ns;
    sp.T_world_frame = (r.T_cam_ref * map.keyframes[r.ref_kf].T_cam_world).inverse();
    out.frames.poses.push_back(sp);
    out.status.push_back(r.status);
    out.frame_segment.push_back(r.segment);
  }
  out.keyframes.source = "StereoSlam keyframes";
  for (const Keyframe& kf : map.keyframes) {
    if (kf.bad) continue;
    out.keyframes.poses.push_back({kf.t_ns, kf.T_cam_world.inverse()});
  }
  stats.keyframes = static_cast<int>(out.keyframes.poses.size());
  stats.map_points = 0;
  for (const MapPoint& p : map.points) stats.map_points += !p.bad;
  stats.finish_s = Seconds(t0);
  out.stats = stats;
  out.map = std::move(map);
  return out;
}

StereoSlam::StereoSlam(const StereoCalibration& rectified, const SlamOptions& options)
    : impl_(std::make_unique<Impl>()) {
  options.Check();
  if (!rectified.rectified)
    throw std::invalid_argument("StereoSlam needs a rectified calibration (rectify raw pairs with StereoRectifier)");
  const double b = rectified.BaselineM();
  if (!(b > 0) || !(rectified.left.fx > 0) || rectified.left.width <= 0 || rectified.left.height <= 0)
    throw std::invalid_argument(fmt::format(
        "StereoSlam: calibration needs baseline > 0, fx > 0 and an image size (baseline {} m, fx {} px, {}x{})", b,
        rectified.left.fx, rectified.left.width, rectified.left.height));
  Impl& s = *impl_;
  s.opt = options;
  s.cam = RectifiedStereoOf(rectified);  // one focal length: fx of the rectified pair
  s.pyr = ScalePyramid(options.pyramid_levels, options.scale_factor);
  s.close_depth_m = options.close_depth_baselines * b;
}

StereoSlam::~StereoSlam() = default;

FrameResult StereoSlam::Track(int64_t t_ns, const cv::Mat& left, const cv::Mat& right,
                              const std::optional<PosePrior>& prior) {
  return impl_->Track(t_ns, left, right, prior);
}

FrameResult StereoSlam::Track(int64_t t_ns, StereoFeatures features, const std::optional<PosePrior>& prior) {
  return impl_->Track(t_ns, std::move(features), prior);
}

const RectifiedStereo& StereoSlam::camera() const { return impl_->cam; }
const SlamOptions& StereoSlam::options() const { return impl_->opt; }
const ScalePyramid& StereoSlam::pyramid() const { return impl_->pyr; }
bool StereoSlam::RegimeDecided() const { return impl_->regime_started && impl_->regime.decided; }

SlamResult StereoSlam::Finish() { return impl_->Finish(); }

}  // namespace rs
