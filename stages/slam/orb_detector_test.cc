#include "stages/slam/orb_detector.h"
#include "stages/slam/fast_corners.h"
#include "tests/support/test_data.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
// The same target set as fast_corners.cc compiles, so every dispatchable target is listed.
#include "stages/slam/highway_targets.h"
// Highway after its target set.
#include <hwy/targets.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace rs {
namespace {

namespace fs = std::filesystem;

fs::path KittiDir() { return rs::test::DataRoot() / "kitti_vo_clips/KITTI_sequence_1"; }
fs::path EurocDir() { return rs::test::DataRoot() / "euroc_v101_micro/tests/data/MicroEurocDataset/mav0/cam0/data"; }

cv::Mat ReadGray(const fs::path& path) {
  cv::Mat img = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  EXPECT_FALSE(img.empty()) << path;
  return img;
}

std::vector<fs::path> SortedPngs(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".png") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// Shapes of random grey levels, blurred, with noise: corners of every strength and many score ties.
cv::Mat SyntheticImage(int rows, int cols, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat img(rows, cols, CV_8UC1, cv::Scalar(100));
  for (int i = 0; i < 300; ++i) {
    const cv::Point a(rng.uniform(0, cols), rng.uniform(0, rows));
    const cv::Point b(a.x + rng.uniform(-60, 60), a.y + rng.uniform(-60, 60));
    const cv::Scalar grey(rng.uniform(0, 256));
    if (i % 3 == 0) cv::rectangle(img, a, b, grey, cv::FILLED);
    if (i % 3 == 1) cv::circle(img, a, rng.uniform(2, 40), grey, cv::FILLED);
    if (i % 3 == 2) cv::line(img, a, b, grey, rng.uniform(1, 4));
  }
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  cv::Mat noise(rows, cols, CV_8UC1);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 6);
  return img + noise;
}

cv::Mat NoiseImage(int rows, int cols, uint64_t seed) {
  cv::Mat img(rows, cols, CV_8UC1);
  cv::RNG(seed).fill(img, cv::RNG::UNIFORM, 0, 256);
  return img;
}

// Every field, floats compared bit for bit.
void ExpectSameKeypoints(const std::vector<cv::KeyPoint>& want, const std::vector<cv::KeyPoint>& got,
                         const std::string& what) {
  ASSERT_EQ(want.size(), got.size()) << what;
  auto bits = [](float f) { return std::bit_cast<uint32_t>(f); };
  for (size_t i = 0; i < want.size(); ++i) {
    const cv::KeyPoint &w = want[i], &g = got[i];
    const bool same = bits(w.pt.x) == bits(g.pt.x) && bits(w.pt.y) == bits(g.pt.y) && bits(w.size) == bits(g.size) &&
                      bits(w.angle) == bits(g.angle) && bits(w.response) == bits(g.response) && w.octave == g.octave &&
                      w.class_id == g.class_id;
    ASSERT_TRUE(same) << what << ": keypoint " << i << " want (" << w.pt.x << ", " << w.pt.y << ") size " << w.size
                      << " angle " << w.angle << " response " << w.response << " octave " << w.octave << " got ("
                      << g.pt.x << ", " << g.pt.y << ") size " << g.size << " angle " << g.angle << " response "
                      << g.response << " octave " << g.octave;
  }
}

void ExpectSameFast(const cv::Mat& img, int threshold, const std::string& what) {
  std::vector<cv::KeyPoint> want, got;
  cv::FAST(img, want, threshold, true, cv::FastFeatureDetector::TYPE_9_16);
  DetectFastCorners(img, threshold, &got);
  ExpectSameKeypoints(want, got, what + " threshold " + std::to_string(threshold));
}

void ExpectSameOrb(const cv::Mat& img, int features, int threshold, const std::string& what) {
  std::vector<cv::KeyPoint> want, got;
  cv::ORB::create(features, 1.2f, 8, 19, 0, 2, cv::ORB::HARRIS_SCORE, 31, threshold)->detect(img, want);
  DetectOrbCorners(img, features, 1.2f, 8, 19, 31, threshold, &got);
  EXPECT_FALSE(want.empty()) << what;
  ExpectSameKeypoints(want, got,
                      what + " features " + std::to_string(features) + " threshold " + std::to_string(threshold));
}

// FAST checks that need no data: noise of many widths (vector tails), tiny images, ROIs, clamped thresholds.
void FastWithoutData() {
  for (int t : {0, 1, 7, 12, 20, 40}) ExpectSameFast(NoiseImage(97, 203, 7), t, "noise 97x203");
  for (int cols = 5; cols <= 140; cols += 3) ExpectSameFast(NoiseImage(11, cols, cols), 10, "noise width");
  for (const cv::Size size : {cv::Size(5, 5), cv::Size(9, 7), cv::Size(70, 13), cv::Size(7, 7), cv::Size(6, 40),
                              cv::Size(40, 6), cv::Size(22, 8), cv::Size(38, 8), cv::Size(134, 9)}) {
    for (int t : {1, 12}) ExpectSameFast(NoiseImage(size.height, size.width, 3), t, "tiny");
  }
  const cv::Mat big = SyntheticImage(300, 420, 5);
  for (int t : {0, 1, 7, 12, 20, 40, 254, 255}) ExpectSameFast(big, t, "synthetic");
  std::vector<cv::KeyPoint> kps;
  EXPECT_THROW(DetectFastCorners(big, -1, &kps), std::invalid_argument);
  EXPECT_THROW(DetectFastCorners(big, 256, &kps), std::invalid_argument);
  ExpectSameFast(big(cv::Rect(13, 7, 301, 250)), 9, "synthetic ROI");
}

TEST(FastCorners, MatchesOpenCvOnNoiseAndTinyImages) { FastWithoutData(); }

TEST(FastCorners, MatchesOpenCvOnKitti) {
  RS_REQUIRE_DATA(KittiDir());
  for (const char* frame : {"image_l/000000.png", "image_r/000017.png", "image_l/000042.png"}) {
    const cv::Mat img = ReadGray(KittiDir() / frame);
    for (int t : {1, 7, 12, 20, 40}) ExpectSameFast(img, t, frame);
    // The coarser ORB levels too.
    cv::Mat small;
    cv::resize(img, small, cv::Size(cvRound(img.cols / 3.583f), cvRound(img.rows / 3.583f)), 0, 0,
               cv::INTER_LINEAR_EXACT);
    ExpectSameFast(small, 12, std::string(frame) + " small");
  }
}

TEST(FastCorners, MatchesOpenCvOnEuroc) {
  RS_REQUIRE_DATA(EurocDir());
  const std::vector<fs::path> pngs = SortedPngs(EurocDir());
  ASSERT_FALSE(pngs.empty());
  const cv::Mat img = ReadGray(pngs[pngs.size() / 2]);
  for (int t : {1, 7, 12, 20, 40}) ExpectSameFast(img, t, "euroc");
}

TEST(OrbCorners, MatchesOpenCvOnSyntheticImage) {
  const cv::Mat img = SyntheticImage(480, 640, 11);
  for (int features : {4000, 2400})
    for (int t : {12, 20}) ExpectSameOrb(img, features, t, "synthetic");
  // Coarse levels too small for any corner, and levels past the edge threshold.
  for (const cv::Size size : {cv::Size(61, 37), cv::Size(160, 90), cv::Size(333, 101)}) {
    std::vector<cv::KeyPoint> want, got;
    const cv::Mat img = SyntheticImage(size.height, size.width, 2);
    cv::ORB::create(500, 1.2f, 8, 19, 0, 2, cv::ORB::HARRIS_SCORE, 31, 7)->detect(img, want);
    DetectOrbCorners(img, 500, 1.2f, 8, 19, 31, 7, &got);
    ExpectSameKeypoints(want, got, "synthetic small");
  }
}

TEST(OrbCorners, MatchesOpenCvOnKitti) {
  RS_REQUIRE_DATA(KittiDir());
  for (const char* side : {"image_l", "image_r"}) {
    for (const char* frame : {"000000.png", "000009.png", "000025.png", "000050.png"}) {
      const cv::Mat img = ReadGray(KittiDir() / side / frame);
      const std::string what = std::string(side) + "/" + frame;
      for (int t : {12, 20}) ExpectSameOrb(img, 4000, t, what);
      ExpectSameOrb(img, 2400, 12, what);
    }
  }
}

TEST(OrbCorners, MatchesOpenCvOnEuroc) {
  RS_REQUIRE_DATA(EurocDir());
  const std::vector<fs::path> pngs = SortedPngs(EurocDir());
  ASSERT_GE(pngs.size(), 3u);
  for (size_t i : {size_t{0}, pngs.size() / 2, pngs.size() - 1}) {
    const cv::Mat img = ReadGray(pngs[i]);
    for (int t : {12, 20}) ExpectSameOrb(img, 4000, t, pngs[i].filename().string());
    ExpectSameOrb(img, 2400, 12, pngs[i].filename().string());
  }
}

// Every compiled SIMD target (SSE4, AVX2, AVX-512, portable fallback) that this CPU runs gives the same corners.
TEST(FastCorners, EveryTargetMatchesOpenCv) {
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  EXPECT_GE(targets.size(), 2u);
  const bool kitti = fs::exists(KittiDir());
  for (int64_t target : targets) {
    SCOPED_TRACE(hwy::TargetName(target));
    hwy::SetSupportedTargetsForTest(target);
    FastWithoutData();
    ExpectSameOrb(SyntheticImage(480, 640, 11), 4000, 12, "synthetic");
    if (kitti) ExpectSameOrb(ReadGray(KittiDir() / "image_l/000009.png"), 4000, 12, "kitti");
  }
  hwy::SetSupportedTargetsForTest(0);
}

}  // namespace
}  // namespace rs
