#include "stages/slam/slam_pipeline.h"

#include <algorithm>
#include <ctime>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>
#include <opencv2/core/utility.hpp>

namespace rs {
namespace {

double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

double SlamPipelineTimes::TwoCoreWallSeconds() const {
  const double overlapped_track = track_cpu_s - serial_cpu_s;
  return serial_cpu_s + std::max(overlapped_track, 0.5 * (extract_cpu_s + overlapped_track));
}

SlamPipeline::SlamPipeline(StereoSlam* slam, bool overlap, int lookahead)
    : slam_(slam), overlap_(overlap), lookahead_(lookahead) {
  if (lookahead < 1) throw std::invalid_argument(fmt::format("SlamPipeline: lookahead {} < 1", lookahead));
  if (overlap_) {
    opencv_threads_before_ = cv::getNumThreads();
    cv::setNumThreads(1);
  }
}

SlamPipeline::~SlamPipeline() {
  WaitForExtraction();  // the threads still reference their images (results are dropped)
  if (overlap_) cv::setNumThreads(opencv_threads_before_);
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
  if (pending_.empty() && !slam_->RegimeDecided()) {
    // Until the first frames have decided the regime, and with it the front end's options
    // (slam_regime.h) that the next extraction reads, each frame is tracked before anything runs beside it.
    const double c0 = ThreadCpuSeconds();
    std::optional<FrameResult> previous = std::exchange(held_, slam_->Track(t_ns, left, right, prior));
    const double cpu = ThreadCpuSeconds() - c0;
    times_.track_cpu_s += cpu;
    times_.serial_cpu_s += cpu;
    return previous;
  }
  Pending next;
  next.t_ns = t_ns;
  next.left = left;
  next.right = right;
  next.prior = prior;
  next.features = StartExtraction(left, right);
  pending_.push_back(std::move(next));
  // held_ exists only when nothing was pending before this frame, so at most one result is due here.
  std::optional<FrameResult> out = std::exchange(held_, std::nullopt);
  if (!out && static_cast<int>(pending_.size()) > lookahead_) out = TrackOldest();
  return out;
}

std::future<SlamPipeline::Extracted> SlamPipeline::StartExtraction(const cv::Mat& left, const cv::Mat& right) const {
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
  return std::async(
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
}

std::vector<FrameResult> SlamPipeline::Flush() {
  std::vector<FrameResult> out;
  if (held_) out.push_back(*std::exchange(held_, std::nullopt));  // the last frame was tracked at its Push
  while (!pending_.empty()) out.push_back(TrackOldest());
  return out;
}

void SlamPipeline::WaitForExtraction() {
  for (Pending& p : pending_)
    if (p.features.valid()) p.features.wait();
}

FrameResult SlamPipeline::TrackOldest() {
  Pending p = std::move(pending_.front());
  pending_.pop_front();
  Extracted e = p.features.get();
  times_.extract_cpu_s += e.left_cpu_s + e.right_cpu_s + e.match_cpu_s;
  const double c0 = ThreadCpuSeconds();
  FrameResult out = slam_->Track(p.t_ns, std::move(e.features), p.prior);
  times_.track_cpu_s += ThreadCpuSeconds() - c0;
  return out;
}

}  // namespace rs
