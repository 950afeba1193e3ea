#pragma once
// Pipeline over StereoSlam: the features of the next frames (ORB of the left and right image, one
// thread each, then the stereo matching on the left image's thread) are computed while an earlier frame
// is tracked and mapped. Feature extraction reads no map state, so the trajectory is bit-identical to
// calling StereoSlam::Track frame by frame; only the wall time drops. Several frames may be extracted
// ahead (lookahead): a keyframe's local mapping takes several frames' worth of extraction time, and
// with one frame ahead the other core would idle through it.

#include <cstdint>
#include <deque>
#include <future>
#include <optional>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "stages/slam/stereo_slam.h"

namespace rs {

/// Per-thread CPU times of a pipelined run (CLOCK_THREAD_CPUTIME_ID), for judging speed on a loaded
/// machine: what the work would take on two free cores.
struct SlamPipelineTimes {
  double extract_cpu_s = 0;  ///< ORB extraction of both images and stereo matching, all frames
  double track_cpu_s = 0;    ///< tracking + local mapping (the calling thread), all frames
  /// Tracking that ran with nothing beside it (frames tracked at their Push while the regime was open).
  double serial_cpu_s = 0;
  /// The wall time of this work on two free cores: serial_cpu_s + max(the rest of the tracking, half of
  /// all the rest) - a lower bound (tracking is one thread; extraction keeps up with it).
  double TwoCoreWallSeconds() const;
};

/// Frames extracted ahead of the tracked one by default: enough to cover a keyframe's local mapping.
inline constexpr int kSlamLookaheadFrames = 3;
/// Stereo pairs the slam stage decodes ahead of the pipeline (StereoPairPrefetcher): one more than
/// a pair's decoding takes of a frame's time keeps the tracking thread from waiting for images.
inline constexpr int kSlamDecodeAheadPairs = 2;

/// Feeds frames to a StereoSlam `lookahead` frames late (until the regime is decided,
/// StereoSlam::RegimeDecided, a frame is tracked at its Push, as it may change the options the next
/// extraction reads; its result still comes with the next Push). Usage:
///   SlamPipeline p(&slam);
///   for (...) if (auto r = p.Push(t_ns, left, right, prior)) use(*r);   // r: the oldest pending frame
///   for (auto& r : p.Flush()) use(r);                                   // the rest, in order
///   slam.Finish();
/// Results come in the order the frames were pushed, one per frame. The images of a pushed frame are read
/// until its result has been returned: do not write into them.
class SlamPipeline {
 public:
  /// overlap = false: extract and track each frame at Push (the sequential reference, same results).
  /// lookahead >= 1: frames whose features may be extracted while an earlier one is tracked.
  /// While an overlapping pipeline exists, OpenCV's own parallel loops run on one thread (its thread count is
  /// restored at destruction): the pipeline's threads already keep the cores busy, and OpenCV's nested
  /// loops inside them only added scheduling (4-5 % of the CPU on the KITTI clip). Results do not change.
  explicit SlamPipeline(StereoSlam* slam, bool overlap = true, int lookahead = kSlamLookaheadFrames);
  ~SlamPipeline();
  SlamPipeline(const SlamPipeline&) = delete;
  SlamPipeline& operator=(const SlamPipeline&) = delete;

  /// Starts extracting this frame's features; when more than `lookahead` frames are pending, tracks the
  /// oldest and returns its result. Throws what StereoSlam::Track throws (wrong image size/type, times
  /// not increasing).
  std::optional<FrameResult> Push(int64_t t_ns, const cv::Mat& left, const cv::Mat& right,
                                  const std::optional<PosePrior>& prior);
  /// Tracks every pending frame; their results in push order.
  std::vector<FrameResult> Flush();
  /// Blocks until every pending frame's extraction has finished.
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
  // Starts the two extraction threads of a frame.
  std::future<Extracted> StartExtraction(const cv::Mat& left, const cv::Mat& right) const;
  // Tracks the oldest pending frame and removes it.
  FrameResult TrackOldest();

  StereoSlam* slam_;
  bool overlap_;
  int lookahead_;
  int opencv_threads_before_ = 0;  // cv::getNumThreads() when an overlapping pipeline was made
  std::deque<Pending> pending_;
  std::optional<FrameResult> held_;  // a frame tracked at its Push (regime undecided), for the next Push or Flush
  SlamPipelineTimes times_;
};

}  // namespace rs
