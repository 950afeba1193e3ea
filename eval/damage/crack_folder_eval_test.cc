// Crack detection on real pavement patches (Crack500 and DeepCrack crops, shared data):
// pixel precision / recall / F1 at a 2 px tolerance, pooled over each split. The full splits
// are scored by `roadsurvey eval cracks DIR`; ROADSURVEY_CRACK_EVAL_DIR=DIR runs the benchmark
// here (_OPTIONS='{...}' crack options, _MAX=n images) and prints the figures.
#include "eval/damage/crack_folder_eval.h"

#include "stages/damage/cracks/crack_model_testing.h"
#include "stages/damage/cracks/crack_net.h"
#include "tests/support/test_data.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>

namespace rs {
namespace {

CrackOptions OptionsFromEnv() {
  const char* env = std::getenv("ROADSURVEY_CRACK_EVAL_OPTIONS");
  if (!env || !*env) return CrackOptions();
  nlohmann::json j = CrackOptions::Table().ToJson(CrackOptions());
  j.merge_patch(nlohmann::json::parse(env));
  CrackOptions o = CrackOptions::Table().FromJson(j);
  o.Check();
  return o;
}

CrackOptions Detector(CrackOptions::Detector d) {
  CrackOptions o;
  o.detector = d;
  return o;
}

void Print(const char* what, const CrackFolderEvaluation& e) {
  const TolerantPixelScore& s = e.overall;
  std::printf("%s, %s: %zu images, P %.3f R %.3f F1 %.3f, %d without a crack detected, %lld px detected, %.1f s\n",
              what, e.detector.c_str(), e.images.size(), s.Precision(), s.Recall(), s.F1(), e.images_without_crack,
              s.predicted, e.wall_s);
}

// The valid splits, whole, the classical (ridge) detector's default options, 2 px tolerance
// (~20 s together). Measured figures
// (docs/results/damage.md, "Cracks on real photographs") beside each bound; the bounds sit 0.02
// below them (images without a detected crack: a few above). Crack500's wide, dark, ragged cracks
// of close-up asphalt are mostly missed (recall 0.16): the figures record it, they do not hide it.
TEST(CrackFolderEval, DeepCrackValid) {
  const auto dir = test::DataRoot() / "crack_patches" / "deepcrack" / "valid";
  RS_REQUIRE_DATA(dir);
  const CrackFolderEvaluation e = EvaluateCrackFolder(dir, Detector(CrackOptions::Detector::kRidge), 2.0);
  Print("deepcrack/valid", e);
  EXPECT_EQ(e.images.size(), 253u);
  EXPECT_GE(e.overall.Precision(), 0.836 - 0.02);  // measured 0.836
  EXPECT_GE(e.overall.Recall(), 0.828 - 0.02);     // measured 0.828
  EXPECT_GE(e.overall.F1(), 0.832 - 0.02);         // measured 0.832
  EXPECT_LE(e.images_without_crack, 3 + 3);        // measured 3
}

TEST(CrackFolderEval, Crack500Valid) {
  const auto dir = test::DataRoot() / "crack_patches" / "crack500" / "valid";
  RS_REQUIRE_DATA(dir);
  const CrackFolderEvaluation e = EvaluateCrackFolder(dir, Detector(CrackOptions::Detector::kRidge), 2.0);
  Print("crack500/valid", e);
  EXPECT_EQ(e.images.size(), 899u);
  EXPECT_GE(e.overall.Precision(), 0.871 - 0.02);  // measured 0.871
  EXPECT_GE(e.overall.Recall(), 0.163 - 0.02);     // measured 0.163
  EXPECT_GE(e.overall.F1(), 0.275 - 0.02);         // measured 0.275
  EXPECT_LE(e.images_without_crack, 434 + 10);     // measured 434
}

// The learned model (trained on the train splits only) on the same valid splits, whole, 2 px
// tolerance (~35 s together); bounds 0.02 below the measured figures (docs/results/damage.md).
// Crack500 F1 0.85 against the classical 0.28; DeepCrack 0.81 against 0.83 (precision 0.73
// against 0.84).
TEST(CrackFolderEval, DeepCrackValidLearned) {
  const auto dir = test::DataRoot() / "crack_patches" / "deepcrack" / "valid";
  RS_REQUIRE_DATA(dir);
  RS_REQUIRE_CRACK_MODEL();
  const CrackFolderEvaluation e = EvaluateCrackFolder(dir, Detector(CrackOptions::Detector::kLearned), 2.0);
  Print("deepcrack/valid", e);
  EXPECT_EQ(e.detector, "learned");
  EXPECT_EQ(e.images.size(), 253u);
  EXPECT_GE(e.overall.Precision(), 0.727 - 0.02);  // measured 0.727
  EXPECT_GE(e.overall.Recall(), 0.918 - 0.02);     // measured 0.918
  EXPECT_GE(e.overall.F1(), 0.811 - 0.02);         // measured 0.811
  EXPECT_LE(e.images_without_crack, 0 + 3);        // measured 0
}

TEST(CrackFolderEval, Crack500ValidLearned) {
  const auto dir = test::DataRoot() / "crack_patches" / "crack500" / "valid";
  RS_REQUIRE_DATA(dir);
  RS_REQUIRE_CRACK_MODEL();
  const CrackFolderEvaluation e = EvaluateCrackFolder(dir, Detector(CrackOptions::Detector::kLearned), 2.0);
  Print("crack500/valid", e);
  EXPECT_EQ(e.detector, "learned");
  EXPECT_EQ(e.images.size(), 899u);
  EXPECT_GE(e.overall.Precision(), 0.848 - 0.02);  // measured 0.848
  EXPECT_GE(e.overall.Recall(), 0.846 - 0.02);     // measured 0.846
  EXPECT_GE(e.overall.F1(), 0.847 - 0.02);         // measured 0.847
  EXPECT_LE(e.images_without_crack, 0 + 10);      // measured 0
}

TEST(CrackFolderEval, Benchmark) {
  const char* dir = std::getenv("ROADSURVEY_CRACK_EVAL_DIR");
  if (!dir || !*dir) GTEST_SKIP() << "set ROADSURVEY_CRACK_EVAL_DIR to a folder with images/ and masks/";
  const char* max = std::getenv("ROADSURVEY_CRACK_EVAL_MAX");
  const char* debug = std::getenv("ROADSURVEY_CRACK_EVAL_DEBUG");
  const CrackFolderEvaluation e =
      EvaluateCrackFolder(dir, OptionsFromEnv(), 2.0, max ? std::atoi(max) : 0, debug ? debug : "");
  if (std::getenv("ROADSURVEY_CRACK_EVAL_VERBOSE"))
    for (const auto& r : e.images)
      std::printf("%-32s P %.3f R %.3f F1 %.3f cracks %d\n", r.name.c_str(), r.score.Precision(), r.score.Recall(),
                  r.score.F1(), r.cracks);
  Print(dir, e);
}

}  // namespace
}  // namespace rs
