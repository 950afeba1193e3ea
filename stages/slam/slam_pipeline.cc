#include "stages/slam/slam_pipeline.h"

#include <algorithm>
#include <ctime>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

namespace rs {
namespace {

double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

SlamPipeline::SlamPipeline(StereoSlam* slam, bool overlap) : slam_(slam), overlap_(overlap) {}

SlamPipeline::~SlamPipeline() {
  WaitForExtraction();  // it still references its images (results are dropped)
}

std::optional<FrameResult> SlamPipeline::Push(int64_t t_ns, const cv::Mat& left, const cv::Mat& right,
                                              const std::optional<PosePrior>& prior) {
  const RectifiedStereo& cam = slam_->camera();
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.cols != cam.width || left.rows != cam.height ||
      right.size() != left.size())
    throw std::invalid_argument(
        fmt::format("SlamPipeline::Push: expected two 8-bit grey {}x{} images, got {}x{} and {}x{}", cam.width,
                    cam.height, left.cols, left.rows, right.cols, right.rows));
  if (!overlap_) return slam_->Track(t_ns, left, right, prior);
  if (!pending_ && !slam_->RegimeDecided()) {
    // Until the first frames have decided the regime, and with it the front end's options
    // (slam_regime.h) that the next extraction reads, each frame is tracked before anything runs beside it.
    const double c0 = ThreadCpuSeconds();
    std::optional<FrameResult> previous = std::exchange(held_, slam_->Track(t_ns, left, right, prior));
    const double cpu = ThreadCpuSeconds() - c0;
    times_.track_cpu_s += cpu;
    times_.two_core_wall_s += cpu;
    return previous;
  }
  Pending next;
  next.t_ns = t_ns;
  next.left = left;
  next.right = right;
  next.prior = prior;
  // Plain threads rather than TBB tasks: the tracking thread does not join TBB's arena, so with two
  // cores TBB would run both extractions on its single worker one after the other.
  const StereoSlam* slam = slam_;
  std::future<std::pair<OrbFeatures, double>> right_orb = std::async(
      std::launch::async,
      [slam](cv::Mat image) {
        const double c0 = ThreadCpuSeconds();
        OrbFeatures f;
        ExtractOrb(image, slam->options(), &f.keypoints, &f.descriptors);
        return std::make_pair(std::move(f), ThreadCpuSeconds() - c0);
      },
      right);
  next.features = std::async(
      std::launch::async,
      [slam](cv::Mat l_image, cv::Mat r_image, std::future<std::pair<OrbFeatures, double>> r_future) {
        Extracted e;
        double c0 = ThreadCpuSeconds();
        OrbFeatures l;
        ExtractOrb(l_image, slam->options(), &l.keypoints, &l.descriptors);
        e.left_cpu_s = ThreadCpuSeconds() - c0;
        auto [r, r_cpu] = r_future.get();
        e.right_cpu_s = r_cpu;
        c0 = ThreadCpuSeconds();
        e.features = MatchStereo(l_image, r_image, std::move(l), r, slam->camera(), slam->options(), slam->pyramid());
        e.match_cpu_s = ThreadCpuSeconds() - c0;
        return e;
      },
      left, right, std::move(right_orb));
  std::optional<FrameResult> out = std::exchange(held_, std::nullopt);
  double track_cpu = 0;
  if (pending_) out = TrackPending(&track_cpu);
  pending_ = std::move(next);
  pending_track_cpu_ = track_cpu;  // accounted with this extraction's CPU when it is collected
  return out;
}

std::optional<FrameResult> SlamPipeline::Flush() {
  if (held_) return std::exchange(held_, std::nullopt);  // the last frame was tracked at its Push
  if (!pending_) return std::nullopt;
  double track_cpu = 0;
  FrameResult r = TrackPending(&track_cpu);
  pending_.reset();
  times_.track_cpu_s += track_cpu;
  times_.two_core_wall_s += track_cpu;  // nothing runs beside the last frame's tracking
  return r;
}

void SlamPipeline::WaitForExtraction() {
  if (pending_ && pending_->features.valid()) pending_->features.wait();
}

FrameResult SlamPipeline::TrackPending(double* cpu_s) {
  Pending& p = *pending_;
  Extracted e = p.features.get();
  // This extraction ran beside the tracking of the frame before it (pending_track_cpu_): one step.
  const double t_cpu = pending_track_cpu_;
  const double x_cpu = e.left_cpu_s + e.right_cpu_s + e.match_cpu_s;
  times_.extract_cpu_s += x_cpu;
  times_.track_cpu_s += t_cpu;
  times_.two_core_wall_s +=
      std::max({std::max(e.left_cpu_s, e.right_cpu_s) + e.match_cpu_s, t_cpu, 0.5 * (x_cpu + t_cpu)});
  pending_track_cpu_ = 0;
  const double c0 = ThreadCpuSeconds();
  FrameResult out = slam_->Track(p.t_ns, std::move(e.features), p.prior);
  *cpu_s = ThreadCpuSeconds() - c0;
  return out;
}

}  // namespace rs
