#pragma once
// The road's local noise for confirming damage, robust to one-sided structure. LocalReliefNoise
// measures the spread above the road level (damage fills only the lower tail); where the road
// itself rises beside a kerb or verge that the road model does not follow, the rise counts as
// noise there (car, truth disparity: 3–5 mm of depth against 0.3–0.8 mm elsewhere) and
// well-measured potholes beside it fail the noise rule. Matching noise (ripples, pixel locking,
// wrong winners) errs both ways, so its spreads above and below the level agree to within
// sampling (our disparity: 10–20 %; damage only raises the one below); a spread above more than
// `max_asymmetry` times the one below is a rise, not noise, and is capped there.

#include <opencv2/core.hpp>

namespace rs {

/// Per-pixel min(σ_up, max_asymmetry · σ_down): `noise_up` is LocalReliefNoise(value, valid, level,
/// cell_px, floor_sigma, max_ratio) (the spread above `level`), σ_down the same for the samples
/// below `level` (mirrored; samples deeper than max_ratio·floor_sigma are damage, not noise; cells
/// with < 35 % of their samples below take their neighbours' value). Never below `floor_sigma`;
/// where the two sides agree within the factor, `noise_up` unchanged.
/// Throws std::invalid_argument as LocalReliefNoise, when noise_up differs from value in size or
/// type, or when max_asymmetry < 1.
cv::Mat TwoSidedReliefNoise(const cv::Mat& noise_up, const cv::Mat& value, const cv::Mat& valid, double level,
                            int cell_px, double floor_sigma, double max_ratio, double max_asymmetry = 2.0);

}  // namespace rs
