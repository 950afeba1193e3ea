#include "formats/stereo/rectifier.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <opencv2/features2d.hpp>

#include "formats/input_error.h"
#include "formats/stereo/calibration_readers.h"
#include "formats/stereo/image_io.h"
#include "tests/support/test_data.h"

namespace rs {
namespace {

namespace fs = std::filesystem;
using rs::test::DataRoot;

const fs::path kEurocMav0 = "euroc_v101_micro/tests/data/MicroEurocDataset/mav0";

// |v_left - v_right| of ORB matches that pass Lowe's ratio test (0.75).
void VerticalOffsets(const cv::Mat& left, const cv::Mat& right, std::vector<double>* dv) {
  auto orb = cv::ORB::create(1500);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  orb->detectAndCompute(left, cv::noArray(), kl, dl);
  orb->detectAndCompute(right, cv::noArray(), kr, dr);
  if (dl.empty() || dr.empty()) return;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(dl, dr, knn, 2);
  for (const auto& m : knn)
    if (m.size() == 2 && m[0].distance < 0.75f * m[1].distance)
      dv->push_back(std::abs(kl[m[0].queryIdx].pt.y - kr[m[0].trainIdx].pt.y));
}

double Quantile(std::vector<double> v, double q) {
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// Rectified EuRoC pairs are row-aligned.
TEST(StereoRectifier, EurocEpipolar) {
  const fs::path mav0 = DataRoot() / kEurocMav0;
  RS_REQUIRE_DATA(mav0);
  const StereoCalibration raw = ReadStereoCalibration(mav0 / "cam0/sensor.yaml");
  const StereoRectifier rect = StereoRectifier::Create(raw);
  EXPECT_TRUE(rect.rectified().rectified);
  EXPECT_NEAR(rect.rectified().BaselineM(), raw.BaselineM(), 1e-9);  // rotation keeps the baseline
  // ORB-SLAM2's settings hold a stereoRectify result for the same rig (fx 435.20); the
  // valid-pixel crop (alpha = 0) differs slightly between OpenCV versions: agree within 1 %.
  EXPECT_NEAR(rect.rectified().left.fx, 435.2046959714599, 4.4);

  std::vector<fs::path> lefts;
  for (const auto& e : fs::directory_iterator(mav0 / "cam0/data")) lefts.push_back(e.path());
  std::sort(lefts.begin(), lefts.end());
  ASSERT_GE(lefts.size(), 90u);
  std::vector<double> before, after;
  for (size_t i = 0; i < lefts.size(); i += 8) {
    const cv::Mat l = LoadGray8(lefts[i]), r = LoadGray8(mav0 / "cam1/data" / lefts[i].filename());
    VerticalOffsets(l, r, &before);
    cv::Mat lr, rr;
    rect.Rectify(l, r, &lr, &rr);
    VerticalOffsets(lr, rr, &after);
  }
  ASSERT_GT(after.size(), 300u);
  const double med_before = Quantile(before, 0.5), med_after = Quantile(after, 0.5);
  // ORB keypoints of pyramid level 0 sit on integer pixels, so many rectified matches have
  // |dv| = 0 exactly; the 75th percentile shows the spread as well.
  std::printf(
      "EuRoC V1_01 (%zu / %zu ORB ratio-test matches): |dv| raw median %.3f px (p75 %.3f), "
      "rectified median %.3f px (p75 %.3f)\n",
      before.size(), after.size(), med_before, Quantile(before, 0.75), med_after, Quantile(after, 0.75));
  RecordProperty("median_dv_raw_px", std::to_string(med_before));
  RecordProperty("median_dv_rectified_px", std::to_string(med_after));
  EXPECT_LT(med_after, 0.5);
  // Ratio-test matches still hold some wrong pairs (repetitive texture), hence no bound on p75.
  auto within1 = [](const std::vector<double>& v) {
    return std::count_if(v.begin(), v.end(), [](double d) { return d < 1.0; }) / double(v.size());
  };
  std::printf("  matches with |dv| < 1 px: raw %.1f %%, rectified %.1f %%\n", 100 * within1(before),
              100 * within1(after));
  EXPECT_GT(within1(after), 0.6);
  EXPECT_GT(med_before, med_after);
}

TEST(StereoRectifier, CacheRoundTrip) {
  const fs::path mav0 = DataRoot() / kEurocMav0;
  RS_REQUIRE_DATA(mav0);
  const StereoCalibration raw = ReadStereoCalibration(mav0 / "cam0/sensor.yaml");
  const fs::path cache = fs::temp_directory_path() / "rs_stereo_rectify_cache.bin";
  fs::remove(cache);
  bool loaded = true;
  const StereoRectifier a = StereoRectifier::LoadOrCreate(raw, cache, 0, &loaded);
  EXPECT_FALSE(loaded);
  EXPECT_LT(fs::file_size(cache), 752u * 480u * 13u);
  const StereoRectifier b = StereoRectifier::LoadOrCreate(raw, cache, 0, &loaded);
  EXPECT_TRUE(loaded);
  EXPECT_EQ(b.rectified().left.fx, a.rectified().left.fx);
  EXPECT_EQ(b.rectified().t_right_left[0], a.rectified().t_right_left[0]);
  EXPECT_EQ(b.R_rectright_right(), a.R_rectright_right());
  const cv::Mat l = LoadGray8(mav0 / "cam0/data/1403715273262142976.png");
  const cv::Mat r = LoadGray8(mav0 / "cam1/data/1403715273262142976.png");
  cv::Mat al, ar, bl, br;
  a.Rectify(l, r, &al, &ar);
  b.Rectify(l, r, &bl, &br);
  EXPECT_EQ(cv::norm(al, bl, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(ar, br, cv::NORM_INF), 0);

  // Another calibration (alpha) does not reuse the cache.
  StereoRectifier::LoadOrCreate(raw, cache, 1.0, &loaded);
  EXPECT_FALSE(loaded);

  // A flipped byte is detected, not used.
  {
    std::fstream f(cache, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(5000);
    f.put('\x5a');
  }
  EXPECT_THROW(StereoRectifier::Load(cache, raw, 1.0), InputError);
  fs::remove(cache);
}

TEST(StereoRectifier, RectifiedIsIdentity) {
  StereoCalibration c;
  c.rectified = true;
  c.left = c.right = {64, 48, 50, 50, 32, 24, {}};
  c.t_right_left = {-0.1, 0, 0};
  const StereoRectifier r = StereoRectifier::Create(c);
  EXPECT_TRUE(r.is_identity());
  cv::Mat l(48, 64, CV_8U, cv::Scalar(7)), rr(48, 64, CV_8U, cv::Scalar(9)), lo, ro;
  r.Rectify(l, rr, &lo, &ro);
  EXPECT_EQ(lo.at<uchar>(10, 10), 7);
  EXPECT_EQ(ro.at<uchar>(10, 10), 9);
  cv::Mat wrong(10, 10, CV_8U);
  EXPECT_THROW(r.Rectify(wrong, wrong, &lo, &ro), InputError);
}

}  // namespace
}  // namespace rs
