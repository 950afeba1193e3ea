#pragma once
// Disparity truth regions of a `roadsurvey simulate` folder (docs/simulator.md): the frames as
// StereoPairWithTruth with a road mask and a pothole mask, so the benchmark scores ours and
// StereoSGBM on exactly the pixels the "Done when" names. Protocol: docs/stages/disparity.md
// ("Simulated road surveys").
//
// Regions (left view, all need a truth disparity):
//   visible  the truth point is inside the right image (0 <= u - d <= W - 1) and not occluded there:
//            no pixel further right in the row maps left of it (u' - d(u') < u - d(u) - 0.5 px);
//   road     visible, on the intact carriageway (|l| <= road_width / 2 - road_edge_margin_m in
//            the simulator's road coordinates, from the truth pose and scene.json), within
//            surface_tolerance_m of the intact surface height (so obstacles are not road), and no
//            damage (truth mask 0);
//   pothole  visible and in the truth mask of a damage whose type is "pothole" (damages.geojson).

#include <filesystem>
#include <vector>

#include "stages/disparity/disparity_eval.h"

namespace rs {

/// Which frames to load and how the road region is cut.
struct SimulatedPairOptions {
  int first_frame = 0;   ///< index of the first frame (sorted file names of left/)
  int frame_step = 1;    ///< every n-th frame from first_frame
  int max_frames = 0;    ///< at most this many frames (0 = all)
  /// Pixels nearer the kerb line than this are not road (the 1 cm kerb ramp, lane edge), m.
  double road_edge_margin_m = 0.05;
  /// Largest |height - intact road height| of a road pixel, m; the truth disparity's 1/256 px
  /// quantisation is added (Z^2 / (f B) / 512) so far pixels of forward views stay in.
  double surface_tolerance_m = 0.02;
};

/// Left-view visibility from the left truth alone (see the header comment). CV_8U 255/0.
cv::Mat VisibleInRightView(const cv::Mat& gt_left, double tolerance_px = 0.5);

/// Loads the chosen frames of the simulated survey `dir` (rectified; truth/disparity present):
/// left/right images, truth disparity, `nonocc` = visible, `road`, `pothole`; plain-SGM range
/// [0, max truth + 8) rounded up to 16. Names "<dir name>/<frame>".
/// Throws InputError naming the file when something is missing or malformed.
std::vector<StereoPairWithTruth> LoadSimulatedSurvey(const std::filesystem::path& dir,
                                                     const SimulatedPairOptions& options = {});

}  // namespace rs
