#pragma once
// One frame's view of the road as height-grid observations: every fused pixel (valid disparity,
// road or damage, not an obstacle) placed in the survey's CRS through the frame's pose, its height
// uncertainty from the stereo depth error σ_Z = Z² σ_d / (f B) carried along the viewing ray, and
// the pixels falling in one cell reduced to their median (robust to single mismatches).

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "formats/rectified_stereo.h"
#include "stages/surface/surface_grid.h"
#include "stages/surface/tile_accumulator.h"

namespace rs {

struct FrameView {
  cv::Mat disparity_px;  ///< CV_32F, ≤ 0 = invalid
  cv::Mat use;           ///< CV_8U, non-zero = fuse this pixel (empty: every valid pixel)
  cv::Mat colour;        ///< CV_8UC3 BGR, same size
  RectifiedStereo camera;
  Eigen::Matrix<double, 3, 4> crs_from_camera = Eigen::Matrix<double, 3, 4>::Zero();  ///< affine, CRS metres
  double sigma_disparity_px = 0.25;  ///< 1-σ disparity error of this frame
  double max_range_m = 0;            ///< pixels deeper than this are left out (0: no limit)
};

/// A pixel's CRS position and height uncertainty; false when it is not fused.
bool PlacePixel(const FrameView& v, int u, int row, Eigen::Vector3d* p, double* sigma_h);

struct CellSample {
  int64_t cell = 0;  ///< row * grid.cols + col
  CellObservation obs;
};

/// The frame's per-cell observations, sorted by cell; pixels outside the grid are dropped.
std::vector<CellSample> FrameCellObservations(const FrameView& v, const SurfaceGrid& grid);

/// CRS x, y of every `stride`-th fused pixel in both directions (the frame's footprint).
std::vector<Eigen::Vector2d> FrameFootprint(const FrameView& v, int stride);

/// Median ground size of the fused pixels, m (Z / f): the finest cell the frame supports.
double MedianPixelFootprintM(const FrameView& v, int stride);

}  // namespace rs
