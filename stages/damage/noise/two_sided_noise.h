#pragma once
// The road's local noise for confirming damage, robust to one-sided structure. LocalReliefNoise
// measures the spread above the road level (damage fills only the lower tail); where the road
// itself rises beside a kerb or verge that the road model does not follow, the rise counts as
// noise there (several times the matching noise elsewhere) and
// well-measured potholes beside it fail the noise rule. Matching noise (ripples, pixel locking,
// wrong winners) errs both ways, so its spreads above and below the level agree to within
// sampling (damage only raises the one below); a spread above more than
// `max_asymmetry` times the one below is a rise, not noise, and is capped there.

#include <opencv2/core.hpp>

namespace rs {

/// Matching noise errs both ways, so its spreads above and below the road agree within this
/// factor; a spread above beyond it is a rise of the road, not noise (the `max_asymmetry`).
inline constexpr double kMatchingNoiseMaxAsymmetry = 2.0;

/// Per-pixel min(σ_up, max_asymmetry · σ_down): `noise_up` is LocalReliefNoise(value, valid, level,
/// cell_px, floor_sigma, max_ratio) (the spread above `level`), σ_down the same for the samples
/// below `level` (mirrored; samples deeper than max_ratio·floor_sigma are damage, not noise; cells
/// with < 35 % of their samples below take their neighbours' value). Never below `floor_sigma`;
/// where the two sides agree within the factor, `noise_up` unchanged.
/// `instances` (optional CV_16U of the value's size, ids 1..n: the found depressions): on each
/// instance's pixels σ_down leaves that instance's own pixels out (leave-one-out: recomputed over
/// its bounding box grown by two cells, cells aligned with the frame's). A pothole filling much of
/// a cell would otherwise measure its own walls as the road's spread below. The other
/// depressions stay in: a wrong-winner patch beside it is the road's noise there (leaving every
/// depression out would let a pair of such patches confirm each other). σ_up keeps every sample.
/// Throws std::invalid_argument as LocalReliefNoise, when noise_up or instances differ from value
/// in size or type, or when max_asymmetry < 1.
cv::Mat TwoSidedReliefNoise(const cv::Mat& noise_up, const cv::Mat& value, const cv::Mat& valid, double level,
                            int cell_px, double floor_sigma, double max_ratio,
                            double max_asymmetry = kMatchingNoiseMaxAsymmetry, const cv::Mat& instances = cv::Mat());

}  // namespace rs
