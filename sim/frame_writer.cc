#include "sim/frame_writer.h"

#include <chrono>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <tbb/parallel_invoke.h>
#include <tbb/task_group.h>

#include "sim/sim_random.h"
#include "sim/truth_writers.h"

namespace rs::sim {
namespace fs = std::filesystem;
namespace {

void WriteImage(const fs::path& path, const cv::Mat& img, const std::vector<int>& params) {
  if (!cv::imwrite(path.string(), img, params)) throw std::runtime_error("cannot write " + path.string());
}

// PNG settings. Only the zlib strategy is given: OpenCV then uses the SUB filter
// at Z_BEST_SPEED, while naming a compression level makes libpng try every
// filter on every row (about 3x the time). Measured on a 1280x720 demo frame:
// grey image 7 ms (Huffman only; 650 KB, smaller than level 1's 710 KB),
// disparity 4 ms (104 KB), mask 3 ms (RLE; 6 KB), against 24, 13 and 10 ms.
const std::vector<int> kGreyPng = {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY};
const std::vector<int> kDisparityPng = {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_DEFAULT};
const std::vector<int> kMaskPng = {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_RLE};

}  // namespace

std::vector<Eigen::Isometry3d> ExposurePoses(const SimulationOptions& o, const FlightPath& path, int k) {
  const double t = k / o.frame_rate_hz;
  const int n = o.motion_blur_samples;
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < n; ++i) {
    const double dt = n > 1 ? o.exposure_s * (static_cast<double>(i) / (n - 1) - 0.5) : 0.0;
    poses.push_back(path.T_world_cam(t + dt));
  }
  return poses;
}

FrameWriter::FrameWriter(const SimulationOptions& o, const fs::path& out_dir, double fx_baseline)
    : out_(out_dir),
      ext_(o.image_format == "jpg" ? ".jpg" : ".png"),
      rectified_(o.rectified),
      fb_(fx_baseline),
      image_params_(o.image_format == "jpg" ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, o.jpeg_quality} : kGreyPng),
      disparity_params_(kDisparityPng),
      mask_params_(kMaskPng) {
  for (const char* d : {"left", "right", "truth/disparity", "truth/masks"}) fs::create_directories(out_ / d);
}

void FrameWriter::Write(const std::string& name, const RenderedView& left, const RenderedView& right) const {
  tbb::parallel_invoke([&] { WriteImage(out_ / "left" / (name + ext_), left.gray, image_params_); },
                       [&] { WriteImage(out_ / "right" / (name + ext_), right.gray, image_params_); },
                       [&] {
                         if (rectified_)
                           WriteImage(out_ / "truth/disparity" / (name + ".png"), DisparityFromDepth(left.depth_m, fb_),
                                      disparity_params_);
                       },
                       [&] { WriteImage(out_ / "truth/masks" / (name + ".png"), left.label, mask_params_); });
}

double RenderAndWriteFrames(const SimulationOptions& o, const FlightPath& path, const StereoRenderer& renderer,
                            const FrameWriter& writer, int first, int count,
                            const std::function<void(int k, const std::string& name)>& after_frame) {
  using Clock = std::chrono::steady_clock;
  RenderedView views[2][2];  // two frames' left and right: one rendering while the other is written
  tbb::task_group writes;
  double render_s = 0;
  for (int i = 0; i < count; ++i) {
    const int k = (first + i) % o.num_frames;
    const std::string name = fmt::format("{:06d}", k);
    RenderedView* view = views[i % 2];
    const auto exposure = ExposurePoses(o, path, k);
    const uint64_t key = HashCombine(static_cast<uint64_t>(o.seed), 1000 + static_cast<uint64_t>(k));
    const auto t0 = Clock::now();
    renderer.Render(exposure, 0, key, true, &view[0]);
    renderer.Render(exposure, 1, key, false, &view[1]);
    render_s += std::chrono::duration<double>(Clock::now() - t0).count();
    writes.wait();  // the previous frame's files; its buffers render the next frame
    writes.run([&writer, name, view] { writer.Write(name, view[0], view[1]); });
    if (after_frame) after_frame(k, name);
  }
  writes.wait();
  return render_s;
}

}  // namespace rs::sim
