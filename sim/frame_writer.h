#pragma once
// The per-frame work of `roadsurvey simulate`: render the left (with truth) and
// right views of each stereo pair and write its four images. Simulate() and the
// throughput benchmark share it, so the benchmark counts exactly what a run costs.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "sim/flight_path.h"
#include "sim/simulation_options.h"
#include "sim/stereo_renderer.h"

namespace rs::sim {

/// Left camera poses over frame k's exposure (motion_blur_samples of them; the middle one is the truth pose).
std::vector<Eigen::Isometry3d> ExposurePoses(const SimulationOptions& o, const FlightPath& path, int k);

/// Writes one frame's left/right images and (left) truth disparity and mask into a survey folder.
class FrameWriter {
 public:
  /// Creates out_dir's left/, right/, truth/disparity/, truth/masks/. fx_baseline: f * B (px m) for disparity.
  FrameWriter(const SimulationOptions& o, const std::filesystem::path& out_dir, double fx_baseline);

  /// Image file extension (".png" or ".jpg").
  const std::string& ext() const { return ext_; }
  /// Encodes and writes `name` (without extension); the four files in parallel.
  void Write(const std::string& name, const RenderedView& left, const RenderedView& right) const;

 private:
  std::filesystem::path out_;
  std::string ext_;
  bool rectified_ = true;
  double fb_ = 0;
  std::vector<int> image_params_, disparity_params_, mask_params_;
};

/// Renders frames first, first + 1, ... first + count - 1 (frame index modulo
/// num_frames) and writes them with `writer`; frame k's files are written while
/// frame k + 1 renders. after_frame(k) runs on the calling thread once frame k is
/// rendered (its files may still be in flight; all are written on return).
/// Returns the seconds spent rendering.
double RenderAndWriteFrames(const SimulationOptions& o, const FlightPath& path, const StereoRenderer& renderer,
                            const FrameWriter& writer, int first, int count,
                            const std::function<void(int k, const std::string& name)>& after_frame = {});

}  // namespace rs::sim
