#pragma once
// Two-stage pipeline over StereoSlam: the features of frame k+1 (ORB of the left and right image, one
// thread each, then the stereo matching on the left image's thread) are computed while frame k is
// tracked and mapped. Feature extraction reads no map state, so the
// trajectory is bit-identical to calling StereoSlam::Track frame by frame; only the wall time drops.

#include <cstdint>
#include <future>
#include <optional>
#include <utility>

#include <opencv2/core/mat.hpp>

#include "stages/slam/stereo_slam.h"

namespace rs {

/// Per-thread CPU times of a pipelined run (CLOCK_THREAD_CPUTIME_ID), for judging speed on a loaded
/// machine: what the work would take on two free cores.
struct SlamPipelineTimes {
  double extract_cpu_s = 0;  ///< ORB extraction of both images and stereo matching, all frames
  double track_cpu_s = 0;    ///< tracking + local mapping (the calling thread)
  /// Sum over pipeline steps (features of frame k+1 beside tracking of frame k) of
  /// max(max(left ORB, right ORB) + matching, tracking, all their CPU / 2): the wall time of those
  /// steps on two free cores.
  double two_core_wall_s = 0;
};

/// Feeds frames to a StereoSlam one frame late (until the regime is decided, StereoSlam::RegimeDecided, a
/// frame is tracked at its Push, as it may change the options the next extraction reads; its result
/// still comes with the next Push). Usage:
///   SlamPipeline p(&slam);
///   for (...) if (auto r = p.Push(t_ns, left, right, prior)) use(*r);   // r: the previous frame
///   if (auto r = p.Flush()) use(*r);                                     // the last frame
///   slam.Finish();
/// The images of a pushed frame are read until the next Push/Flush returns: do not write into them.
class SlamPipeline {
 public:
  /// overlap = false: extract and track each frame at Push (the sequential reference, same results).
  explicit SlamPipeline(StereoSlam* slam, bool overlap = true);
  ~SlamPipeline();
  SlamPipeline(const SlamPipeline&) = delete;
  SlamPipeline& operator=(const SlamPipeline&) = delete;

  /// Starts extracting this frame's features, then tracks the frame pushed before (its result).
  /// Throws what StereoSlam::Track throws (wrong image size/type, times not increasing).
  std::optional<FrameResult> Push(int64_t t_ns, const cv::Mat& left, const cv::Mat& right,
                                  const std::optional<PosePrior>& prior);
  /// Tracks the last pushed frame, if any.
  std::optional<FrameResult> Flush();
  /// Blocks until the pushed frame's extraction has finished (benchmarks: nothing of the SLAM then
  /// runs while the caller loads the next images, so that time can be excluded exactly).
  void WaitForExtraction();
  /// CPU accounting so far (overlap mode only; zeros otherwise).
  const SlamPipelineTimes& times() const { return times_; }

 private:
  // A frame's features with the CPU seconds of its two threads: left ORB then the stereo matching
  // (after the right one), and the right ORB.
  struct Extracted {
    StereoFeatures features;
    double left_cpu_s = 0, match_cpu_s = 0, right_cpu_s = 0;
  };
  struct Pending {
    int64_t t_ns = 0;
    cv::Mat left, right;
    std::optional<PosePrior> prior;
    std::future<Extracted> features;
  };
  // Tracks the pending frame; *cpu_s receives the calling thread's CPU time for it.
  FrameResult TrackPending(double* cpu_s);

  StereoSlam* slam_;
  bool overlap_;
  std::optional<Pending> pending_;
  std::optional<FrameResult> held_;  // a frame tracked at its Push (regime undecided), for the next Push or Flush
  SlamPipelineTimes times_;
  double pending_track_cpu_ = 0;  // CPU of the tracking that ran beside the pending frame's extraction
};

}  // namespace rs
