#pragma once
// Smoothing of the road relief against stereo matching noise: a normalised box filter over
// valid pixels whose window may change from row to row, so that in an oblique view (car) it
// covers a square on the road instead of a strip foreshortened along the driving direction.

#include "stages/damage/road/road_surface.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

namespace rs {

/// A view is oblique where a pixel is at least this many times longer on the road along the
/// column than across (RoadRowElongation): superpixels are shaped and rims extended for it.
inline constexpr double kObliqueElongation = 1.5;

/// Road length of a pixel along the image column / across it, per image row, at the principal
/// column, for a road plane with unit `normal` towards the camera: 1 for a camera facing the
/// road, ~3.5 for a car camera 1.5 m high looking at road 5 m ahead; 1 where the ray misses the
/// road. Clamped to [1/16, 16].
std::vector<double> RoadRowElongation(int rows, const RectifiedStereo& geometry, const Eigen::Vector3d& normal);

/// Box-filter window (width, height in px, both odd) for each of `rows` image rows.
/// `ground` false: window_px × window_px everywhere. `ground` true: about window_px² pixels
/// (the same number of samples, so the same noise reduction) shaped so that the window is
/// square on the road plane (unit `normal` towards the camera) at the principal column:
/// height window_px / √e, width window_px² / height, e = road length of a pixel along the
/// image column / across it (1 for a camera facing the road, ~3.5 for a car camera 1.5 m
/// high at 5 m). Rows whose ray misses the road keep the square window.
std::vector<cv::Size> ReliefSmoothWindows(int rows, const RectifiedStereo& geometry, const Eigen::Vector3d& normal,
                                          int window_px, bool ground);

/// Normalised box filter over valid pixels of the relief's transformed disparity and depth
/// (invalid pixels stay invalid and do not contribute; pixels beyond the image count as
/// invalid); row v of `relief` uses windows[row0 + v]. Bit-identical to one full-frame box
/// filter when every row has the same window.
/// `edge_sigma` > 0: a pixel whose transformed disparity differs from its smoothed value by more
/// than edge_sigma × σ keeps its own values (both images): a step that stands out of the
/// matching noise (a pothole's rim, its near wall's occlusion edge) is not smeared onto the road
/// beside it. σ = `noise_px` if > 0, else measured here: 1.4826 × the median |value − smoothed|
/// over valid pixels (every 4th row and column). Returns the σ used (0 when edge_sigma ≤ 0).
double SmoothReliefRows(RoadRelief& relief, const std::vector<cv::Size>& windows, int row0, double edge_sigma = 0,
                        double noise_px = 0);

}  // namespace rs
