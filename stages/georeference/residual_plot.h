#pragma once
// georeference_residuals.png: the GNSS residuals (fix minus fitted antenna) of every fitted frame
// over time, one panel per ENU axis, outliers in red, the robust 3-sigma band dashed. OpenCV only.

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "stages/georeference/georeference.h"

namespace rs {

/// No residuals: the title alone (it says why).
cv::Mat PlotGnssResiduals(const std::vector<GnssResidual>& residuals, const Eigen::Vector3d& sigma_axis_m,
                          const std::string& title);

/// The plot as PNG through the checked writer.
void WriteGnssResidualPlot(const std::filesystem::path& png, const std::vector<GnssResidual>& residuals,
                           const Eigen::Vector3d& sigma_axis_m, const std::string& title);

}  // namespace rs
