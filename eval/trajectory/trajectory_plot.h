#pragma once
// A picture of an estimated trajectory against its ground truth (`roadsurvey eval trajectory --plot`):
// top view of both paths after the ATE alignment, and below it the ATE error of every pose over time.
// Drawn with OpenCV only.

#include <filesystem>
#include <string>

#include <opencv2/core/mat.hpp>

#include "eval/trajectory/trajectory_metrics.h"

namespace rs {

/// Size and labels of the plot.
struct TrajectoryPlotOptions {
  int width_px = 1400;        ///< image width
  int top_height_px = 700;    ///< height of the top-view panel
  int error_height_px = 300;  ///< height of the error-over-time panel
  std::string title;          ///< first line of text, e.g. the estimate's file name
};

/// Renders the associated pairs: truth positions and the aligned estimate (alignment.Apply) in the
/// truth's horizontal (x, y) plane with equal axis scales, and |gt_i - S(est_i)| over time.
/// Throws std::invalid_argument for fewer than 2 pairs.
cv::Mat PlotTrajectory(const PosePairs& pairs, const Sim3Transform& alignment, const TrajectoryPlotOptions& options);

/// PlotTrajectory written as PNG; throws std::runtime_error when the file cannot be written.
void WriteTrajectoryPlot(const std::filesystem::path& png, const PosePairs& pairs, const Sim3Transform& alignment,
                         const TrajectoryPlotOptions& options);

}  // namespace rs
