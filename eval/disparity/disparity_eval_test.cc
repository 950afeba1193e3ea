#include "eval/disparity/disparity_eval.h"
#include "tests/support/test_data.h"

#include <cstdlib>
#include <filesystem>

#include <gtest/gtest.h>

#include "formats/input_error.h"
#include "eval/disparity/disparity_benchmark.h"

namespace rs {
namespace {

std::string DataRoot() { return rs::test::DataRoot().string(); }

TEST(DisparityEval, Nominal) {
  cv::Mat gt(1, 6, CV_32F), est(1, 6, CV_32F), valid(1, 6, CV_8U, cv::Scalar(255));
  const float g[] = {10, 10, 10, 100, 0, 10}, e[] = {10.5f, 11.5f, 14, 104, 50, 0};
  for (int i = 0; i < 6; ++i) gt.at<float>(0, i) = g[i], est.at<float>(0, i) = e[i];
  valid.at<uint8_t>(0, 5) = 0;  // invalid estimate on a truth pixel
  const DisparityMetrics m = EvaluateDisparity(est, valid, gt);
  EXPECT_EQ(m.evaluated, 5);  // gt = 0 is unknown
  EXPECT_DOUBLE_EQ(m.density, 4.0 / 5);
  EXPECT_DOUBLE_EQ(m.bad1, 4.0 / 5);  // errors 0.5, 1.5, 4, 4 + invalid
  EXPECT_DOUBLE_EQ(m.bad2, 3.0 / 5);
  EXPECT_DOUBLE_EQ(m.bad3, 3.0 / 5);
  EXPECT_DOUBLE_EQ(m.d1, 2.0 / 5);  // 4 px on 100 is < 5 %
  EXPECT_DOUBLE_EQ(m.bad2_est, 2.0 / 4);
  EXPECT_DOUBLE_EQ(m.d1_est, 1.0 / 4);
  EXPECT_DOUBLE_EQ(m.epe, (0.5 + 1.5 + 4 + 4) / 4);
  cv::Mat region = cv::Mat::zeros(1, 6, CV_8U);
  region.at<uint8_t>(0, 0) = 255;
  EXPECT_DOUBLE_EQ(EvaluateDisparity(est, valid, gt, region).epe, 0.5);
}

TEST(DisparityEval, NonOccluded) {
  cv::Mat gl(1, 8, CV_32F, cv::Scalar(2)), gr(1, 8, CV_32F, cv::Scalar(2));
  gr.at<float>(0, 3) = 5;  // inconsistent for left pixel 5
  const cv::Mat m = NonOccludedMask(gl, gr);
  EXPECT_EQ(m.at<uint8_t>(0, 0), 0);  // u - d < 0
  EXPECT_EQ(m.at<uint8_t>(0, 2), 255);
  EXPECT_EQ(m.at<uint8_t>(0, 5), 0);
}

TEST(DisparityEval, MissingMiddlebury) { EXPECT_THROW(LoadMiddlebury("/nonexistent"), InputError); }

// Our SGM must beat OpenCV StereoSGBM on bad-2 (non-occluded, invalid = bad) on every pair.
TEST(DisparityEval, MiddleburyBeatsStereoSgbm) {
  const std::string root = DataRoot() + "/middlebury";
  if (!std::filesystem::exists(root)) GTEST_SKIP() << "no Middlebury data at " << root << " (set ROADSURVEY_DATA)";
  const auto pairs = LoadMiddlebury(root);
  ASSERT_EQ(pairs.size(), 4u);
  for (const auto& p : pairs) {
    DisparityParams q;
    q.method = DisparityMethod::kSgm;
    q.min_disparity = p.min_disparity, q.num_disparities = p.num_disparities;
    const DisparityResult r = ComputeDisparity(p.left, p.right, q);
    const DisparityMetrics ours = EvaluateDisparity(r.disparity, r.valid, p.gt, p.nonocc);
    cv::Mat d, valid;
    RunStereoSgbm(p.left, p.right, p.min_disparity, p.num_disparities, false, &d, &valid);
    const DisparityMetrics sgbm = EvaluateDisparity(d, valid, p.gt, p.nonocc);
    std::printf("%-9s bad-2 nonocc: ours %.2f %% (density %.1f %%), StereoSGBM %.2f %% (density %.1f %%)\n",
                p.name.c_str(), 100 * ours.bad2, 100 * ours.density, 100 * sgbm.bad2, 100 * sgbm.density);
    EXPECT_GT(ours.evaluated, p.gt.total() / 2);
    EXPECT_LT(ours.bad2, sgbm.bad2) << p.name;
  }
}

}  // namespace
}  // namespace rs
