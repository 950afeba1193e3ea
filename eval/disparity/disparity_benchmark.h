#pragma once
// Side-by-side benchmark on the same pairs in one process: our GPT-SGM and SGM against
// OpenCV StereoSGBM (MODE_SGBM and MODE_SGBM_3WAY), time per pair (median of repetitions,
// methods interleaved so machine load hits all alike) and accuracy.

#include <string>
#include <vector>

#include "stages/disparity/disparity.h"
#include "eval/disparity/disparity_eval.h"

namespace rs {

/// One method on one pair.
struct BenchMethodResult {
  std::string method;            ///< "gpt-sgm", "sgm", "sgbm", "sgbm-3way"
  double median_ms = 0;          ///< median wall time per pair
  std::vector<double> times_ms;  ///< every repetition
  /// Median process CPU time per pair (all threads). On a machine shared with other jobs the
  /// wall time depends on their load; CPU time is close to what the work costs.
  double median_cpu_ms = 0;
  std::vector<double> cpu_ms;
  DisparityEvaluation eval;  ///< all / non-occluded / road-mask metrics
  int num_disparities = 0;   ///< disparities searched
  bool fell_back = false;    ///< GPT-SGM fell back to plain SGM (no reliable road model)
  DisparityTimings timings;  ///< our methods: step times of the last repetition
};

/// All methods on one pair.
struct BenchPairResult {
  std::string pair;
  int width = 0, height = 0;
  std::vector<BenchMethodResult> methods;
  /// median_ms of `method` divided by median_ms of `baseline` (same run), or 0 if absent.
  double Ratio(const std::string& method, const std::string& baseline) const;
  const BenchMethodResult* Find(const std::string& method) const;
};

/// OpenCV StereoSGBM as the baseline: grey input, blockSize 5, P1 = 8*cn*bs^2, P2 = 32*cn*bs^2,
/// uniquenessRatio 10, disp12MaxDiff 1, speckle window 100 / range 2, numDisparities rounded up
/// to a multiple of 16. Returns CV_32F disparity (0 invalid) and the validity mask.
void RunStereoSgbm(const cv::Mat& left, const cv::Mat& right, int min_disparity, int num_disparities, bool three_way,
                   cv::Mat* disparity, cv::Mat* valid);

/// Runs every method `repetitions` times per pair. `ours` gives our parameters; the plain
/// range of each pair comes from the pair itself.
/// `only`: run just this method ("gpt-sgm", "sgm", "sgbm", "sgbm-3way"; empty = all four).
std::vector<BenchPairResult> RunDisparityBenchmark(const std::vector<StereoPairWithTruth>& pairs,
                                                   const DisparityParams& ours, int repetitions,
                                                   const std::string& only = "");

/// Markdown table of our methods' step times (last repetition), ms.
std::string FormatStepTimes(const std::vector<BenchPairResult>& results);

/// Markdown table of road and pothole accuracy (pairs that carry those masks), one row per
/// survey and method: metrics pooled over the survey's pairs (pair names "<survey>/<frame>"),
/// median times over its pairs, road D1 beside the better StereoSGBM mode's.
std::string FormatRoadAccuracyTable(const std::vector<BenchPairResult>& results);

/// Markdown table: pair, method, ms/pair, pairs/s, ratio to sgbm-3way, density, bad-2 and D1 (non-occluded), EPE.
std::string FormatBenchmarkTable(const std::vector<BenchPairResult>& results);

}  // namespace rs
