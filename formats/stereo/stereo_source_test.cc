#include "formats/stereo/stereo_source.h"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "formats/stereo/calibration_yaml.h"
#include "tests/support/test_data.h"

namespace rs {
namespace {

namespace fs = std::filesystem;
using rs::test::DataRoot;

bool HasProblem(const ProblemList& p, const std::string& where, const std::string& needle) {
  for (const auto& i : p.items())
    if (i.where.ToString().find(where) != std::string::npos && i.message.find(needle) != std::string::npos) return true;
  return false;
}

std::string Dump(const ProblemList& p) {
  std::string s;
  for (const auto& i : p.items()) s += i.ToString() + "\n";
  return s;
}

TEST(StereoSource, KittiOdometry) {
  const fs::path root = DataRoot() / "kitti_vo_clips/KITTI_sequence_1";
  RS_REQUIRE_DATA(root);
  EXPECT_EQ(DetectLayout(root), StereoLayout::kKittiOdometry);
  const StereoSource s = OpenStereoSource(root);
  ASSERT_EQ(s.frames().size(), 51u);
  EXPECT_EQ(s.frames()[10].left, root / "image_l/000010.png");
  EXPECT_EQ(s.frames()[10].right, root / "image_r/000010.png");
  // No times.txt in this copy: nominal 10 Hz, flagged.
  EXPECT_TRUE(s.timestamps_synthesized());
  EXPECT_EQ(s.frames()[10].t_ns, 1'000'000'000);
  EXPECT_TRUE(HasProblem(s.warnings(), "times.txt", "synthesized"));
  ASSERT_TRUE(s.calibration().has_value());
  EXPECT_EQ(s.calibration()->left.width, 1226);  // from the first image
  EXPECT_EQ(s.calibration()->left.height, 370);
  EXPECT_NEAR(s.calibration()->BaselineM(), 379.8145 / 707.0912, 1e-12);
  ProblemList p;
  EXPECT_EQ(ValidateStereoFolder(root, "auto", &p), 51);
  EXPECT_FALSE(p.HasErrors()) << Dump(p);
}

TEST(StereoSource, KittiRaw) {
  const fs::path root = DataRoot() / "kitti_raw_tiny/KITTI_tiny/2011_09_26/2011_09_26_drive_0023_sync";
  RS_REQUIRE_DATA(root);
  EXPECT_EQ(DetectLayout(root), StereoLayout::kKittiRaw);
  const StereoSource s = OpenStereoSource(root, "kitti-raw");
  ASSERT_EQ(s.frames().size(), 7u);
  // "2011-09-26 13:17:59.287203584" as UTC: `date -u -d '2011-09-26 13:17:59' +%s` = 1317043079.
  EXPECT_EQ(s.frames()[0].t_ns, 1317043079'287203584);
  EXPECT_EQ(s.frames()[6].where.line, 7);
  EXPECT_EQ(s.frames()[3].right, root / "image_03/data/0000000003.png");
  ASSERT_TRUE(s.calibration().has_value());
  EXPECT_TRUE(s.calibration()->rectified);
  EXPECT_EQ(s.calibration()->left.width, 1242);
  EXPECT_NEAR(s.calibration()->BaselineM(), 0.5327119287764802, 1e-12);
  ProblemList p;
  EXPECT_EQ(ValidateStereoFolder(root, "auto", &p), 7);
  EXPECT_FALSE(p.HasErrors()) << Dump(p);
}

TEST(StereoSource, Euroc) {
  const fs::path root = DataRoot() / "euroc_v101_micro/tests/data/MicroEurocDataset";
  RS_REQUIRE_DATA(root);
  EXPECT_EQ(DetectLayout(root), StereoLayout::kEuroc);
  const StereoSource s = OpenStereoSource(root);
  ASSERT_EQ(s.frames().size(), 95u);
  EXPECT_EQ(s.frames()[0].t_ns, 1403715273262142976);
  EXPECT_EQ(s.frames()[0].where.line, 2);
  EXPECT_EQ(s.frames()[94].right.filename(), "1403715277962142976.png");
  // cam1/data.csv lists 4 stamps beyond cam0's last frame.
  EXPECT_TRUE(HasProblem(s.warnings(), "cam1/data.csv", "4 timestamp(s) without a cam0 frame"));
  ASSERT_TRUE(s.calibration().has_value());
  EXPECT_FALSE(s.calibration()->rectified);
  EXPECT_NEAR(s.calibration()->BaselineM(), 0.1100778421917135, 1e-9);
}

// A small plain-layout folder written like the simulator writes it.
struct PlainFixture {
  fs::path root;
  explicit PlainFixture(const std::string& name, int n = 5) {
    root = fs::temp_directory_path() / ("rs_stereo_plain_" + name);
    fs::remove_all(root);
    fs::create_directories(root / "left");
    fs::create_directories(root / "right");
    std::ofstream csv(root / "timestamps.csv");
    csv << "filename,t_ns\n";
    for (int i = 0; i < n; ++i) {
      const std::string f = "f" + std::to_string(i) + ".png";
      WriteImage(root / "left" / f, 40, 30);
      WriteImage(root / "right" / f, 40, 30);
      csv << f << "," << 1'000'000'000LL + i * 50'000'000LL << "\n";
    }
    StereoCalibration c;
    c.rectified = true;
    c.left = c.right = {40, 30, 35, 35, 20, 15, {}};
    c.t_right_left = {-0.3, 0, 0};
    WriteCalibrationYaml(root / "calibration.yaml", c);
  }
  ~PlainFixture() { fs::remove_all(root); }
  static void WriteImage(const fs::path& p, int w, int h) {
    cv::Mat m(h, w, CV_8U);
    cv::randu(m, 0, 255);
    cv::imwrite(p.string(), m);
  }
  void WriteCsv(const std::string& text) { std::ofstream(root / "timestamps.csv") << text; }
};

TEST(StereoSource, PlainNominal) {
  PlainFixture fx("nominal");
  EXPECT_EQ(DetectLayout(fx.root), StereoLayout::kPlain);
  const StereoSource s = OpenStereoSource(fx.root);
  ASSERT_EQ(s.frames().size(), 5u);
  EXPECT_EQ(s.frames()[2].t_ns, 1'100'000'000);
  EXPECT_EQ(s.frames()[2].where.line, 4);
  ASSERT_TRUE(s.calibration().has_value());
  EXPECT_DOUBLE_EQ(s.calibration()->BaselineM(), 0.3);
  ProblemList p;
  EXPECT_EQ(ValidateStereoFolder(fx.root, "plain", &p), 5);
  EXPECT_TRUE(p.items().empty()) << Dump(p);
}

TEST(StereoSource, PlainAllProblemsCollected) {
  PlainFixture fx("bad", 8);
  fx.WriteCsv(
      "filename,t_ns\n"
      "f0.png,1000\n"
      "f1.png,2000\n"
      "f2.png,2000\n"    // line 4: duplicate
      "f3.png,1500\n"    // line 5: non-monotonic
      "f4.png,12.5\n"    // line 6: not an integer
      "f5.png,6000\n"    // line 7: right image removed below
      "f6.png,7000\n"    // line 8: truncated left image
      "f7.png,8000\n");  // line 9: wrong size
  fs::remove(fx.root / "right/f5.png");
  fs::resize_file(fx.root / "left/f6.png", 100);
  PlainFixture::WriteImage(fx.root / "left/f7.png", 41, 30);
  PlainFixture::WriteImage(fx.root / "right/f7.png", 41, 30);

  EXPECT_THROW(OpenStereoSource(fx.root), InputError);  // ingest stops at the first
  ProblemList p;
  EXPECT_EQ(ValidateStereoFolder(fx.root, "auto", &p), 2);  // f0, f1
  const std::string csv = "timestamps.csv";
  EXPECT_TRUE(HasProblem(p, csv + ":4", "duplicate timestamp")) << Dump(p);
  EXPECT_TRUE(HasProblem(p, csv + ":5", "non-monotonic")) << Dump(p);
  EXPECT_TRUE(HasProblem(p, csv + ":6", "not an integer")) << Dump(p);
  // A missing image is a warning (ingest skips the frame), reported once.
  EXPECT_TRUE(HasProblem(p, csv + ":7", "right/f5.png does not exist: the frame is skipped")) << Dump(p);
  EXPECT_FALSE(HasProblem(p, "right/f5.png", "cannot open image")) << Dump(p);
  EXPECT_TRUE(HasProblem(p, "left/f6.png", "truncated PNG")) << Dump(p);
  EXPECT_TRUE(HasProblem(p, csv + ":9", "differs from the calibration")) << Dump(p);
  EXPECT_TRUE(HasProblem(p, "rs_stereo_plain_bad", "left/ holds 8 images but right/ holds 7")) << Dump(p);
  EXPECT_EQ(p.ErrorCount(), 5) << Dump(p);

  // As a run sees them (bad frames skipped): the frame problems are warnings saying so.
  ProblemList listing, images;
  const StereoSource source = OpenStereoSource(fx.root, "auto", &listing);
  ValidateStereoImages(source, &images, true);
  EXPECT_EQ(images.ErrorCount(), 0) << Dump(images);
  EXPECT_TRUE(HasProblem(images, "left/f6.png", "will be skipped")) << Dump(images);
  EXPECT_TRUE(HasProblem(images, csv + ":9", "differs from the calibration")) << Dump(images);
}

TEST(StereoSource, PlainBadHeaderAndUnknownLayout) {
  PlainFixture fx("header", 2);
  fx.WriteCsv("file,time\nf0.png,1\nf1.png,2\n");
  ProblemList p;
  ValidateStereoFolder(fx.root, "plain", &p);
  EXPECT_TRUE(HasProblem(p, "timestamps.csv:1", "header")) << Dump(p);
  EXPECT_THROW(OpenStereoSource(fx.root, "zed"), InputError);
  EXPECT_THROW(DetectLayout(fx.root / "left"), InputError);
}

}  // namespace
}  // namespace rs
