#pragma once
// How much of the road a single stereo pair fills in the surface grid: the pair's disparity with the
// disparity stage's defaults, each valid pixel placed on the road plane's grid exactly as the
// surface stage places a frame (rs_surface_core), against the cells of the road visible in both
// views (the road model's disparity keeps the point inside the right image). For real pairs that
// have no poses (Fan 2021 model3). `roadsurvey eval surface-pairs`.

#include <filesystem>
#include <string>
#include <vector>

namespace rs {

struct PairDensityRow {
  std::string left;
  double cell_m = 0;
  double pixel_m = 0;          ///< median ground size of a pixel
  int64_t visible_cells = 0;   ///< road cells visible in both views
  int64_t filled_cells = 0;    ///< of those, cells with at least one valid pixel
  double filled_fraction = 0;
  double pixel_density = 0;    ///< valid pixels / visible pixels (the disparity's own density)
};

/// Every pair L<i>.png / R<i>.png of a folder laid out as Fan 2021's model3 (left images/,
/// right images/, calibration_rectified.yaml), at each of `cells_m`. Throws InputError naming a
/// missing or unreadable file.
std::vector<PairDensityRow> EvaluatePairDensity(const std::filesystem::path& dir, const std::vector<double>& cells_m);

std::string PairDensityTable(const std::vector<PairDensityRow>& rows);

}  // namespace rs
