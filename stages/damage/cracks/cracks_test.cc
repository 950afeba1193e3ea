#include "stages/damage/cracks/cracks.h"

#include "stages/damage/cracks/crack_model_testing.h"
#include "stages/damage/cracks/crack_net.h"
#include "tests/support/test_data.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace rs {
namespace {

// The classical detector in pixel units (the default, auto, runs the learned model there when
// its file exists).
CrackOptions Ridge() {
  CrackOptions o;
  o.detector = CrackOptions::Detector::kRidge;
  return o;
}

CrackOptions Learned() {
  CrackOptions o;
  o.detector = CrackOptions::Detector::kLearned;
  return o;
}

cv::Mat Asphalt(unsigned seed) {
  cv::Mat noise(480, 640, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, 12);
  cv::GaussianBlur(noise, noise, {0, 0}, 1.2);
  cv::Mat img;
  noise.convertTo(img, CV_8U, 1.0, 128);
  return img;
}

// A dark 5 px wide line, 412 px long, at 2 mm per pixel: length 0.825 m ± 10 %,
// mean width 10 mm ± 3 mm (±1.5 px), FHWA moderate needs 6–19 mm.
TEST(DetectCracks, Nominal) {
  cv::Mat img = Asphalt(1);
  cv::line(img, {100, 200}, {500, 300}, cv::Scalar(60), 5, cv::LINE_8);
  const cv::Mat px(img.size(), CV_32F, cv::Scalar(0.002));
  const CrackDetection c = DetectCracks(img, cv::Mat(), cv::Mat(), px, CrackOptions());
  ASSERT_EQ(c.instances.size(), 1u);
  const DamageInstance& d = c.instances[0];
  const double true_len = std::hypot(400.0, 100.0) * 0.002;
  EXPECT_EQ(d.type, DamageType::kCrack);
  EXPECT_NEAR(d.length_m, true_len, 0.10 * true_len);
  EXPECT_NEAR(d.mean_width_m, 0.010, 0.003);
  EXPECT_GE(d.max_width_m, d.mean_width_m);
  EXPECT_GT(d.confidence, 0.5);
}

TEST(DetectCracks, TextureOnly) {
  const cv::Mat img = Asphalt(2);
  const cv::Mat px(img.size(), CV_32F, cv::Scalar(0.002));
  EXPECT_TRUE(DetectCracks(img, cv::Mat(), cv::Mat(), px, CrackOptions()).instances.empty());
}

TEST(DetectCracks, ExcludedAndOffRoad) {
  cv::Mat img = Asphalt(3);
  cv::line(img, {100, 200}, {500, 300}, cv::Scalar(60), 5, cv::LINE_8);
  cv::Mat road = cv::Mat::zeros(img.size(), CV_8U);
  road(cv::Rect(0, 0, 640, 100)).setTo(255);  // the crack is off the road
  EXPECT_TRUE(DetectCracks(img, road, cv::Mat(), cv::Mat(), Ridge()).instances.empty());
  EXPECT_THROW(DetectCracks(cv::Mat(10, 10, CV_32F), cv::Mat(), cv::Mat(), cv::Mat(), Ridge()), std::invalid_argument);
}

// Without calibration (ridge detector, pixel units): a dark line 3 px wide and one 15 px wide
// on textured asphalt are found, each as one crack whose region spans the line: region area /
// line length between the drawn width and 4 px more (measured +2.5 and +2.8 px: the half-depth
// test admits the texture's dark pixels beside the line, σ 12 grey levels against a 58 deep
// line); the texture alone gives nothing.
// A hairline one and two pixels wide (a 2–12 mm crack seen from 6 m at 6 mm per pixel), kinked,
// so its 8-connected pixels step sideways: one crack each, length within 10 %, width within a
// pixel of the drawn one. A fixed 5 × 5 median before the thinning erased such lines, and
// thinning them unwidened broke them into short pieces.
TEST(DetectCracks, HairlineOneAndTwoPixelsWide) {
  constexpr double kPixel = 0.006;
  const std::vector<cv::Point> kinked = {{300, 40}, {340, 240}, {310, 440}};
  const double length_m = (cv::norm(kinked[1] - kinked[0]) + cv::norm(kinked[2] - kinked[1])) * kPixel;
  for (const int width : {1, 2}) {
    cv::Mat img = Asphalt(7);
    cv::polylines(img, kinked, false, cv::Scalar(80), width, cv::LINE_8);
    const cv::Mat px(img.size(), CV_32F, cv::Scalar(kPixel));
    const CrackDetection c = DetectCracks(img, cv::Mat(), cv::Mat(), px, CrackOptions());
    ASSERT_EQ(c.instances.size(), 1u) << width;
    const DamageInstance& d = c.instances[0];
    EXPECT_NEAR(d.length_m, length_m, 0.10 * length_m) << width;
    EXPECT_NEAR(d.mean_width_m, width * kPixel, kPixel) << width;
  }
}

TEST(DetectCracks, RidgeInPixelUnits) {
  EXPECT_TRUE(DetectCracks(Asphalt(4), cv::Mat(), cv::Mat(), cv::Mat(), Ridge()).instances.empty());
  for (const int width : {3, 15}) {
    cv::Mat img = Asphalt(5);
    const cv::Point a(80, 120), b(560, 360);
    cv::line(img, a, b, cv::Scalar(70), width, cv::LINE_AA);
    const CrackDetection c = DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), Ridge());
    ASSERT_EQ(c.instances.size(), 1u) << width;
    const double mean_width = cv::countNonZero(c.labels) / cv::norm(b - a);
    EXPECT_GE(mean_width, width) << width;
    EXPECT_LE(mean_width, width + 4.0) << width;
  }
}

// A road seen obliquely: pixel size 8 mm at the top row to 2 mm at the bottom (4×, as a car
// camera from 10 to 2.5 m). Coarse aggregate (bright 8 mm stones, 12 mm apart, on dark binder)
// is resolved at the bottom and blurred into grey at the top; one 10 mm crack crosses it.
struct ObliqueRoad {
  cv::Mat image, pixel_size;
  double crack_length_m = 0;
};

ObliqueRoad MakeObliqueRoad(bool with_crack) {
  const int w = 640, h = 480;
  auto ps = [&](double v) { return 0.008 - 0.006 * v / (h - 1); };
  ObliqueRoad r;
  r.pixel_size = cv::Mat(h, w, CV_32F);
  for (int v = 0; v < h; ++v) r.pixel_size.row(v).setTo(ps(v));
  cv::Mat img(h, w, CV_32F, cv::Scalar(90));
  cv::RNG rng(7);
  for (double v = 0; v < h; v += 0.012 / ps(v))
    for (double u = 0; u < w; u += 0.012 / ps(v)) {
      const double s = 0.012 / ps(v);
      const cv::Point2d c(u + rng.uniform(0.0, s), v + rng.uniform(0.0, s));
      cv::circle(img, cv::Point(cvRound(c.x * 4), cvRound(c.y * 4)), cvRound(4 * 0.004 / ps(c.y)),
                 cv::Scalar(rng.uniform(150, 190)), cv::FILLED, cv::LINE_8, 2);
    }
  if (with_crack) {  // 10 mm wide on the road: 5 px at the bottom, 1.25 px at the top
    const cv::Point2d a(150, 40), b(520, 450);
    const int n = 2000;
    for (int i = 0; i <= n; ++i) {
      const cv::Point2d p = a + (b - a) * (double(i) / n);
      cv::circle(img, cv::Point(cvRound(p.x * 4), cvRound(p.y * 4)), cvRound(4 * 0.005 / ps(p.y)), cv::Scalar(35),
                 cv::FILLED, cv::LINE_8, 2);
      if (i < n) r.crack_length_m += cv::norm(b - a) / n * ps(p.y);
    }
  }
  cv::Mat noise(h, w, CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0, 4);
  cv::GaussianBlur(img + noise, img, {0, 0}, 0.8);  // camera blur
  img.convertTo(r.image, CV_8U);
  return r;
}

// Element sized on the road, opening, local level and line support: the resolved aggregate near
// the camera is no crack, the crack across it is found whole: length ±20 % (measured +15.6 %:
// the 1.25 px-wide far end is widened and extended by the blur), width 10 ± 4 mm.
TEST(DetectCracks, ObliqueAggregateIsNoCrack) {
  const ObliqueRoad plain = MakeObliqueRoad(false);
  EXPECT_TRUE(DetectCracks(plain.image, cv::Mat(), cv::Mat(), plain.pixel_size, CrackOptions()).instances.empty());

  const ObliqueRoad cracked = MakeObliqueRoad(true);
  const CrackDetection c = DetectCracks(cracked.image, cv::Mat(), cv::Mat(), cracked.pixel_size, CrackOptions());
  ASSERT_EQ(c.instances.size(), 1u);
  EXPECT_NEAR(c.instances[0].length_m, cracked.crack_length_m, 0.20 * cracked.crack_length_m);
  EXPECT_NEAR(c.instances[0].mean_width_m, 0.010, 0.004);
}

// Real imagery (fan2019 dataset3, left images, 1710 × 1028, no calibration: pixel scales): the
// default (auto: the ridge on whole frames) never paints whole road areas. Measured crack share of
// the image per frame printed; bound 3 % (measured 1.1–1.7 %). The learned model, forced, is
// printed beside it on one frame: it marks 14.6 % of it (8.6–14.6 % of the five; far from its
// close-up training patches),
// which is why auto keeps the classical detector on frames.
TEST(DetectCracks, Fan2019NoCrackPaint) {
  const auto dir = test::DataRoot() / "pothole_stereo_fan2019" / "dataset3" / "rgb";
  RS_REQUIRE_DATA(dir);
  const bool model = std::filesystem::exists(DefaultCrackModelPath());
  for (int i = 1; i <= 5; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%02d.png", i);
    const cv::Mat img = cv::imread((dir / name).string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(img.empty()) << name;
    const CrackDetection c = DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), CrackOptions());
    EXPECT_EQ(c.detector, CrackOptions::Detector::kRidge) << name;
    const double share = cv::countNonZero(c.labels) / double(c.labels.total());
    std::printf("fan2019 dataset3 %s, auto (ridge): %zu cracks, %.2f %% of the image\n", name, c.instances.size(),
                100 * share);
    EXPECT_LE(share, 0.03) << name;
    if (model && i == 1) {  // one frame: the learned model on a whole frame takes seconds
      const CrackDetection l = DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), Learned());
      std::printf("fan2019 dataset3 %s, learned: %zu cracks, %.2f %% of the image\n", name, l.instances.size(),
                  100 * cv::countNonZero(l.labels) / double(l.labels.total()));
    }
  }
}

TEST(CrackDetector, AutoResolves) {
  CrackOptions o;  // auto
  const cv::Size patch(213, 121), frame(1710, 1028);
  EXPECT_EQ(ResolveCrackDetector(o, true, patch), CrackOptions::Detector::kRidge);   // calibrated: classical
  EXPECT_EQ(ResolveCrackDetector(o, false, frame), CrackOptions::Detector::kRidge);  // a whole frame: classical
  o.model = "/nonexistent/crack_net.onnx";
  EXPECT_EQ(ResolveCrackDetector(o, false, patch), CrackOptions::Detector::kRidge);  // no model file: classical
  EXPECT_STREQ(CrackDetectorName(CrackOptions::Detector::kRidge, true), "black-hat");
  EXPECT_STREQ(CrackDetectorName(CrackOptions::Detector::kRidge, false), "ridge");
  o.model.clear();
  if (std::filesystem::exists(DefaultCrackModelPath())) {
    EXPECT_EQ(ResolveCrackDetector(o, false, patch), CrackOptions::Detector::kLearned);
  }
  o.detector = CrackOptions::Detector::kBlackHat;
  EXPECT_EQ(ResolveCrackDetector(o, false, frame), CrackOptions::Detector::kBlackHat);
}

// `learned` without its model file: the options check and the detector name the path.
TEST(CrackDetector, LearnedModelMissing) {
  CrackOptions o = Learned();
  o.model = "/nonexistent/crack_net.onnx";
  try {
    o.Check();
    ADD_FAILURE() << "no error";
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/crack_net.onnx"), std::string::npos) << e.what();
  }
  try {
    DetectCracks(Asphalt(1), cv::Mat(), cv::Mat(), cv::Mat(), o);
    ADD_FAILURE() << "no error";
  } catch (const CrackModelError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/crack_net.onnx"), std::string::npos) << e.what();
  }
}

// A model file that is no network (and one without its JSON): errors that name the file.
TEST(CrackDetector, CorruptModel) {
  const auto dir = std::filesystem::temp_directory_path() / ("rs_crack_model_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto onnx = dir / "bad.onnx";
  std::ofstream(onnx) << "not a network";
  CrackOptions o = Learned();
  o.model = onnx.string();
  auto message = [&] {
    try {
      DetectCracks(Asphalt(1), cv::Mat(), cv::Mat(), cv::Mat(), o);
    } catch (const CrackModelError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string without_json = message();
  EXPECT_NE(without_json.find((dir / "bad.json").string()), std::string::npos) << without_json;
  std::ofstream(dir / "bad.json") << R"({"threshold": 0.5})";
  const std::string corrupt = message();
  EXPECT_NE(corrupt.find(onnx.string()), std::string::npos) << corrupt;
  EXPECT_NE(corrupt.find("not an ONNX network"), std::string::npos) << corrupt;
  std::filesystem::remove_all(dir);
}

// The committed model on a dark line drawn on synthetic asphalt (far from the photographs it
// learned from): found as one long crack along the line; the texture alone (8 seeds) gives no crack.
// Frames processed in parallel give what one thread gives (one network per thread).
TEST(CrackDetector, LearnedNominal) {
  RS_REQUIRE_CRACK_MODEL();
  for (unsigned seed = 1; seed <= 8; ++seed)  // flatter than any training photograph: not stretched into cracks
    EXPECT_TRUE(DetectCracks(Asphalt(seed), cv::Mat(), cv::Mat(), cv::Mat(), Learned()).instances.empty()) << seed;
  cv::Mat img = Asphalt(5);
  const cv::Point a(80, 120), b(560, 360);
  cv::line(img, a, b, cv::Scalar(60), 5, cv::LINE_AA);
  const CrackDetection c = DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), Learned());
  EXPECT_EQ(c.detector, CrackOptions::Detector::kLearned);
  ASSERT_GE(c.instances.size(), 1u);
  cv::Mat line = cv::Mat::zeros(img.size(), CV_8U);
  cv::line(line, a, b, cv::Scalar(255), 1);
  const double on_line = cv::countNonZero(line & (c.labels != 0)) / double(cv::countNonZero(line));
  EXPECT_GE(on_line, 0.8);
  std::vector<CrackDetection> parallel(6);
  tbb::parallel_for(0, 6, [&](int i) { parallel[i] = DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), Learned()); });
  for (const CrackDetection& p : parallel) EXPECT_EQ(cv::countNonZero(p.labels != c.labels), 0);
}

// The component rules come with the model (its JSON's "components", chosen on the training
// hold-out) and replace the options' min_length_px / min_elongation for the learned detector; bad
// rules are an error naming the JSON.
TEST(CrackDetector, ModelComponentRules) {
  RS_REQUIRE_CRACK_MODEL();
  cv::Mat img = Asphalt(5);
  cv::line(img, {80, 120}, {560, 360}, cv::Scalar(60), 5, cv::LINE_AA);  // about 540 px long
  const auto root = std::filesystem::temp_directory_path() / ("rs_crack_rules_" + std::to_string(::getpid()));
  nlohmann::json meta =
      nlohmann::json::parse(std::ifstream(std::filesystem::path(DefaultCrackModelPath()).replace_extension(".json")));
  auto model_with = [&](const std::string& name, const nlohmann::json& components) {
    const auto dir = root / name;
    std::filesystem::create_directories(dir);
    std::filesystem::copy_file(DefaultCrackModelPath(), dir / "crack_net.onnx");
    nlohmann::json m = meta;
    m["components"] = components;
    std::ofstream(dir / "crack_net.json") << m.dump();
    CrackOptions o = Learned();
    o.model = (dir / "crack_net.onnx").string();
    return o;
  };
  CrackOptions longer = model_with("longer", {{"min_length_px", 2000}, {"min_elongation", 1}});
  EXPECT_TRUE(DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), longer).instances.empty());
  CrackOptions shorter = model_with("shorter", {{"min_length_px", 10}, {"min_elongation", 1}});
  shorter.min_length_px = 2000;  // the model's rule wins
  EXPECT_GE(DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), shorter).instances.size(), 1u);
  CrackOptions bad = model_with("bad", {{"min_length_px", 1}, {"min_elongation", 1}});
  try {
    DetectCracks(img, cv::Mat(), cv::Mat(), cv::Mat(), bad);
    ADD_FAILURE() << "no error";
  } catch (const CrackModelError& e) {
    EXPECT_NE(std::string(e.what()).find((root / "bad" / "crack_net.json").string()), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace rs
